"""The Zenoh keys of the Open-RMF topics the bridge speaks, as a ROS 2 building names them.

Open-RMF's names, defined once here (they are the building's, not wheelnav's keys, which
all come from shared/topics.py): a fleet adapter asks the door and lift supervisors on
``adapter_door_requests`` / ``adapter_lift_requests`` and hears the doors and lifts on
``door_states`` / ``lift_states`` (rmf_fleet_adapter's StandardNames.hpp).

Two ways a ROS 2 topic appears on Zenoh (``rmf_bridge.key_format``):

* ``ros2dds``, zenoh-bridge-ros2dds: the topic's name without its leading ``/``, after the
  bridge's ``namespace``: ``/door_states`` is ``door_states``, or ``building1/door_states``
  with ``namespace: /building1``.
* ``rmw_zenoh``, ROS 2 nodes on rmw_zenoh_cpp:
  ``<domain id>/<namespace>/<topic>/<DDS type name>/<type hash>``, e.g.
  ``0/door_states/rmf_door_msgs::msg::dds_::DoorState_/RIHS01_1cb9...``. The bridge
  publishes with the RIHS01 hash of its bundled definitions (as Jazzy and later name it)
  and subscribes with any hash (``*``: Humble writes ``TypeHashNotSupported``; a building
  built from other definitions shows up as malformed messages rather than as silence).

Pure.
"""

from __future__ import annotations

from dataclasses import dataclass

from services.rmf_bridge import cdr

KEY_FORMATS = ("ros2dds", "rmw_zenoh")
# the deepest zenoh-bridge-ros2dds namespace a secured router lets through (key_patterns)
NAMESPACE_DEPTH = 2


@dataclass(frozen=True)
class RosTopic:
    """One Open-RMF topic: its ROS 2 name (without the leading ``/``) and message type."""

    name: str
    typename: str
    direction: str  # "in": the building publishes it, "out": the bridge does


DOOR_STATES = RosTopic("door_states", cdr.DOOR_STATE, "in")
DOOR_REQUESTS = RosTopic("adapter_door_requests", cdr.DOOR_REQUEST, "out")
LIFT_STATES = RosTopic("lift_states", cdr.LIFT_STATE, "in")
LIFT_REQUESTS = RosTopic("adapter_lift_requests", cdr.LIFT_REQUEST, "out")
TOPICS = (DOOR_STATES, DOOR_REQUESTS, LIFT_STATES, LIFT_REQUESTS)


def ros_key(
    topic: RosTopic, key_format: str = "ros2dds", namespace: str = "", domain_id: int = 0
) -> str:
    """The Zenoh key of ``topic`` in a building whose topics carry ``namespace`` (a ROS
    namespace, with or without its leading ``/``; empty: none); ValueError naming an
    unknown ``key_format``."""
    return _key(topic, key_format, namespace.strip("/"), str(domain_id))


def key_patterns(topic: RosTopic) -> tuple[str, ...]:
    """The key expressions of ``topic`` in any namespace (zenoh-bridge-ros2dds: at most
    :data:`NAMESPACE_DEPTH` levels) and any domain, in both key formats.

    For a secured router's rules (wheelnav/security/acl.py), made from the credentials
    folder alone, without the fleet config that names the building's namespace and domain.
    The depth bound keeps them off wheelnav's own keys: ``**/door_states`` would also match
    ``wheelnav/chair1/events/door_states``, a service's events forged.
    """
    ros2dds = [_key(topic, "ros2dds", "/".join(["*"] * n), "") for n in range(NAMESPACE_DEPTH + 1)]
    return (*ros2dds, _key(topic, "rmw_zenoh", "**", "*"))


def beyond_secured(key_format: str, namespace: str) -> bool:
    """Whether :func:`key_patterns` miss the keys of ``namespace``, so that a secured router
    drops them: a zenoh-bridge-ros2dds namespace deeper than :data:`NAMESPACE_DEPTH`."""
    depth = len([p for p in namespace.split("/") if p])
    return key_format == "ros2dds" and depth > NAMESPACE_DEPTH


def _key(topic: RosTopic, key_format: str, namespace: str, domain: str) -> str:
    name = "/".join(p for p in (namespace, topic.name) if p)
    if key_format == "ros2dds":
        return name
    if key_format == "rmw_zenoh":
        typename = topic.typename
        type_hash = "*" if topic.direction == "in" else cdr.type_hash(typename)
        return f"{domain}/{name}/{cdr.dds_type_name(typename)}/{type_hash}"
    raise ValueError(f"key format {key_format!r}: use one of {', '.join(KEY_FORMATS)}")
