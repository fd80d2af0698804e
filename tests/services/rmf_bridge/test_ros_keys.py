"""The Zenoh keys of Open-RMF's topics, as zenoh-bridge-ros2dds and rmw_zenoh name them."""

from __future__ import annotations

import pytest

from services.rmf_bridge import cdr
from services.rmf_bridge.ros_keys import (
    DOOR_REQUESTS,
    DOOR_STATES,
    LIFT_REQUESTS,
    LIFT_STATES,
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
