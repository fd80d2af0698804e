"""The Zenoh keys of Open-RMF's topics, as zenoh-bridge-ros2dds and rmw_zenoh name them, and
the patterns a secured router allows them by."""

from __future__ import annotations

import pytest
import zenoh

from services.rmf_bridge import cdr
from services.rmf_bridge.ros_keys import (
    DOOR_REQUESTS,
    DOOR_STATES,
    KEY_FORMATS,
    LIFT_REQUESTS,
    LIFT_STATES,
    TOPICS,
    RosTopic,
    beyond_secured,
    key_patterns,
    ros_key,
)


def test_zenoh_bridge_ros2dds_keys_are_the_topic_names_under_its_namespace() -> None:
    assert [ros_key(t) for t in (DOOR_STATES, DOOR_REQUESTS, LIFT_STATES, LIFT_REQUESTS)] == [
        "door_states",
        "adapter_door_requests",
        "lift_states",
        "adapter_lift_requests",
    ]
    for namespace in ("building1", "/building1", "/building1/"):
        assert ros_key(DOOR_STATES, namespace=namespace) == "building1/door_states"
    assert ros_key(LIFT_STATES, namespace="/site/b2") == "site/b2/lift_states"


def test_rmw_zenoh_keys_carry_domain_type_and_hash_out_and_any_hash_in() -> None:
    key = ros_key(DOOR_REQUESTS, "rmw_zenoh", namespace="/building1", domain_id=7)
    domain, ns, topic, dds_type, type_hash = key.split("/")
    assert (domain, ns, topic) == ("7", "building1", "adapter_door_requests")
    assert dds_type == "rmf_door_msgs::msg::dds_::DoorRequest_"
    assert type_hash == cdr.type_hash(cdr.DOOR_REQUEST)
    # what the building publishes is heard whatever hash its ROS 2 release writes
    assert (
        ros_key(LIFT_STATES, "rmw_zenoh") == "0/lift_states/rmf_lift_msgs::msg::dds_::LiftState_/*"
    )
    with pytest.raises(ValueError, match="key format 'dds'"):
        ros_key(DOOR_STATES, "dds")


@pytest.mark.parametrize("topic", TOPICS, ids=lambda t: t.name)
def test_a_secured_routers_patterns_hold_every_key_up_to_two_namespace_levels(
    topic: RosTopic,
) -> None:
    patterns = [zenoh.KeyExpr(p) for p in key_patterns(topic)]
    for key_format in KEY_FORMATS:
        for namespace in ("", "/building1", "/site/b2", "/site/b2/wing"):
            for domain_id in (0, 7):
                key = zenoh.KeyExpr(ros_key(topic, key_format, namespace, domain_id))
                held = any(p.includes(key) for p in patterns)
                assert held != beyond_secured(key_format, namespace), (key, held)
    assert beyond_secured("ros2dds", "/site/b2/wing")  # the one miss: the node warns of it
    assert not beyond_secured("rmw_zenoh", "/site/b2/wing")
