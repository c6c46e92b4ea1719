"""Benchmarks, one module an area, each run as `robotrial bench AREA`.

Each module has `HELP`, `add_arguments(parser)` and `run(args) -> int`; it prints a table,
writes JSON (`-o/--output`), and measures its baseline in the same run.
"""
