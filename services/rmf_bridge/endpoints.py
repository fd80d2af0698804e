"""What the building bridge reads and writes, on each side, named once.

The node declares exactly these, and a secured router grants the ``rmf_bridge`` identity
exactly these beyond what every service may do (wheelnav/security/acl.py): the topic table
names the building emulator as the publisher of door and lift states, and the bridge
stands in for it on a real chair. Pure.
"""

from __future__ import annotations

from services.rmf_bridge.ros_keys import TOPICS, RosTopic

NAME = "rmf_bridge"
# wheelnav's topics (shared/topics.py): the chair's requests in, the building's states out
SUBSCRIBES = ("door_request", "lift_request")
PUBLISHES = ("door_state", "lift_state")
# Open-RMF's topics: the building's states in, the chair's requests out
ROS_SUBSCRIBES: tuple[RosTopic, ...] = tuple(t for t in TOPICS if t.direction == "in")
ROS_PUBLISHES: tuple[RosTopic, ...] = tuple(t for t in TOPICS if t.direction == "out")
