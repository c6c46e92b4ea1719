"""The options that say who may reach a server: `--allow-origin`, `--token`, `--token-file`."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from robotrial.ros.rosbridge.access import Access


def add_access_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--allow-origin",
        action="append",
        default=[],
        metavar="ORIGIN",
        help="also accept browser pages from this origin (e.g. https://studio.foxglove.dev; "
        "'*' for any); by default only the server's own page and clients without an Origin",
    )
    parser.add_argument(
        "--token",
        help="require this token for everything but the page itself: rosbridge clients send "
        "{op: auth, mac: TOKEN} or connect with ?token=TOKEN, other requests send "
        "Authorization: Bearer TOKEN; the page opened with ?token=TOKEN carries it",
    )
    parser.add_argument("--token-file", metavar="FILE", help="read the token from a file")


def access_from(args: argparse.Namespace) -> Access:
    """The Access rule the options describe; ValueError naming the bad option."""
    from robotrial.ros.rosbridge.access import Access, read_token

    token = read_token(args.token, args.token_file)
    return Access.create(args.host, args.allow_origin, token)
