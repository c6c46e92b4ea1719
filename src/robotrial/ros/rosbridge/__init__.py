"""The rosbridge v2 server: ROS web and Python tools reach the bus through it (layer 4).

- `protocol`: the per-client protocol (`RosbridgeServer`, `Session`), transport-free;
- `encoding`: JSON, CBOR, PNG and fragments on the wire;
- `rosapi`: the discovery services (`/rosapi/topics`, `message_details`, params...);
- `transport`: the WebSocket route for the web app and the standalone server.
"""

from robotrial.ros.rosbridge.protocol import Limits, RosbridgeServer, Session
from robotrial.ros.rosbridge.transport import add_rosbridge_route, serve, standalone_app

__all__ = [
    "Limits",
    "RosbridgeServer",
    "Session",
    "add_rosbridge_route",
    "serve",
    "standalone_app",
]
