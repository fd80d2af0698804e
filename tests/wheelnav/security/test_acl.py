"""The router's rules derived from the topic table: who may publish, query, serve, hold;
and the building bridge's to Open-RMF, on wheelnav's keys and the building's."""

from __future__ import annotations

import pytest
import zenoh

from services.rmf_bridge import endpoints
from services.rmf_bridge.ros_keys import KEY_FORMATS, RosTopic, key_patterns, ros_key
from services.rmf_bridge.ros_keys import TOPICS as ROS_TOPICS
from shared.topics import TOPICS, Keys, Topic
from wheelnav.security.acl import (
    HOST,
    OPERATOR,
    RMF,
    SERVICE,
    VIEWER,
    Identity,
    access_control,
    carried,
    grants,
    phrases,
    upstream_keys,
)
from wheelnav.security.store import SERVICE_NAMES

IDS = [
    *(Identity(n, SERVICE) for n in SERVICE_NAMES),
    Identity("alice", OPERATOR),
    Identity("bob", VIEWER),
]
G = grants(TOPICS, IDS, "chair1")


def may(name: str, action: str, key: str) -> bool:
    return key in G[name].get(action, [])


def test_words_of_a_column_drop_qualifiers_and_keep_parenthesised_commas_together() -> None:
    assert phrases("sim / chair driver") == ["sim", "chair driver"]
    assert phrases("navigator (get)") == ["navigator"]
    assert phrases("wheelnav stop, a (re)starting holder (get)") == [
        "wheelnav stop",
        "a (re)starting holder",
    ]
    assert phrases("evaluation only (mission report, viz)") == ["evaluation only"]


def test_every_row_of_the_topic_table_has_known_publishers() -> None:
    assert set(G) == {i.name for i in IDS}  # grants() raised on any unknown word


def test_only_the_controller_publishes_velocities() -> None:
    cmd = "wheelnav/chair1/cmd_vel"
    assert [n for n in G if may(n, "publish", cmd)] == ["controller"]


def test_only_operators_and_the_mission_runner_send_goals_and_cancels() -> None:
    goal = "wheelnav/chair1/nav/goal"
    assert sorted(n for n in G if may(n, "publish", goal)) == ["alice", "mission"]


def test_a_viewer_only_reads_and_everyone_reads_everything() -> None:
    assert G["bob"] == {"read": ["wheelnav/**"]}
    assert all("wheelnav/**" in G[n]["read"] for n in G)
    # beyond: the building bridge reads the building's states, outside wheelnav/**
    assert [n for n in G if G[n]["read"] != ["wheelnav/**"]] == ["rmf_bridge"]


def test_a_service_offers_diagnostics_events_and_its_token_on_its_own_key_only() -> None:
    assert may("planner", "publish", "wheelnav/chair1/diagnostics/planner")
    assert may("planner", "publish", "wheelnav/chair1/events/planner")
    assert G["planner"]["token"] == ["wheelnav/chair1/alive/planner"]
    assert not any("controller" in k for k in G["planner"]["publish"])


def test_queries_the_navigator_asks_the_planner_answers() -> None:
    route = "wheelnav/chair1/planner/route"
    assert may("navigator", "query", route) and may("planner", "serve", route)
    assert not may("alice", "query", route) and not may("navigator", "serve", route)


def test_a_holder_serves_its_own_state_and_queries_the_others() -> None:
    assert may("controller", "serve", "wheelnav/chair1/estop/state/controller")
    assert may("controller", "query", "wheelnav/chair1/estop/state/*")
    assert may("alice", "query", "wheelnav/chair1/estop/state/*")
    assert "serve" not in G["alice"]


def test_a_lockstep_participant_acks_ticks() -> None:
    ack = "wheelnav/chair1/clock/ack"
    assert {n for n in G if may(n, "publish", ack)} == {
        "localisation",
        "building",
        "controller",
        "navigator",
        "mission",
    }


def test_an_unknown_publisher_word_names_the_topic_and_the_word() -> None:
    row = Topic("odd", "{ns}/odd", None, "pub", "navigator, the janitor", "any", "")
    with pytest.raises(ValueError, match="topic 'odd': who is 'the janitor'"):
        grants([row], IDS, "chair1")


def test_the_zenoh_config_denies_by_default_and_binds_names_to_certificates() -> None:
    acl = access_control(G)
    assert acl["enabled"] is True and acl["default_permission"] == "deny"
    assert all(r["permission"] == "allow" for r in acl["rules"])
    rule_ids = [r["id"] for r in acl["rules"]]
    assert len(rule_ids) == len(set(rule_ids))
    subjects = {s["id"]: s for s in acl["subjects"]}
    assert subjects["controller"] == {
        "id": "controller",
        "cert_common_names": ["controller"],
        "usernames": ["controller"],
    }
    for policy in acl["policies"]:
        assert set(policy["rules"]) <= set(rule_ids) and policy["subjects"] == [policy["id"]]
    cmd_rules = [r for r in acl["rules"] if "wheelnav/chair1/cmd_vel" in r["key_exprs"]]
    assert [(r["id"], r["flows"], r["messages"]) for r in cmd_rules] == [
        ("controller/publish/ingress", ["ingress"], ["put"]),
        # a publisher hears of the subscribers: with none, nothing is sent
        ("controller/publish/egress", ["egress"], ["declare_subscriber"]),
    ]


HOSTS = [
    *IDS,
    Identity("laptop", HOST, ("@operators", "@viewers")),
    Identity("building-host", HOST, ("building",)),
]
H = grants(TOPICS, HOSTS, "chair1")


def test_a_hosts_router_may_do_what_the_identities_it_carries_may_do_no_more() -> None:
    assert carried(HOSTS[-2], HOSTS) == ["alice", "bob"]
    assert H["laptop"]["publish"] == H["alice"]["publish"]  # goals, cancels, stops
    assert "wheelnav/chair1/cmd_vel" not in H["laptop"]["publish"]
    building = H["building-host"]
    assert "wheelnav/building/door/*/state" in building["publish"]
    assert building["token"] == ["wheelnav/chair1/alive/building"]
    assert "wheelnav/chair1/nav/goal" not in building["publish"]
    assert {n: G[n] for n in G} == {n: H[n] for n in G}  # the others' rules are unchanged


def test_a_hosts_router_hears_of_the_queryables_its_clients_may_ask() -> None:
    # routers forward a query only to the queryables they heard of: the chair's router
    # declares them to the laptop's, for an operator's `wheelnav stop` (estop states)
    assert H["laptop"]["route"] == H["laptop"]["query"] == ["wheelnav/chair1/estop/state/*"]
    acl = access_control({"laptop": H["laptop"]})
    route = next(r for r in acl["rules"] if r["id"] == "laptop/route/egress")
    assert route["messages"] == ["declare_queryable"] and route["flows"] == ["egress"]


def test_a_host_carrying_a_word_that_names_nobody_is_refused() -> None:
    with pytest.raises(ValueError, match="carries 'bobby': neither an identity nor one of"):
        carried(Identity("laptop", HOST, ("bobby",)), HOSTS)


def test_a_hosts_router_trusts_the_chairs_router_known_by_its_certificate() -> None:
    acl = access_control({"alice": G["alice"]}, upstream=["wheelnav/**"])
    (up,) = [s for s in acl["subjects"] if s["id"] == "upstream"]
    assert up == {"id": "upstream", "cert_common_names": ["router"]}  # no username: it accepts
    (rule,) = [r for r in acl["rules"] if r["id"] == "upstream"]
    assert rule["key_exprs"] == ["wheelnav/**"] and set(rule["flows"]) == {"ingress", "egress"}
    assert {"put", "query", "reply", "declare_queryable"} <= set(rule["messages"])
    assert "upstream" not in str(access_control({"alice": G["alice"]}))


RMF_HOSTS = [*IDS, Identity("building-rmf", HOST, (RMF,))]
R = grants(TOPICS, RMF_HOSTS, "chair1")
KEYS = Keys("chair1")


def allows(name: str, action: str, key: str) -> bool:
    """Whether ``name``'s rules of ``action`` cover ``key`` as Zenoh matches them (a rule's
    key expression may be a pattern, and so may ``key``: a subscription's)."""
    key_expr = zenoh.KeyExpr(key)
    return any(zenoh.KeyExpr(k).includes(key_expr) for k in R[name].get(action, []))


def building_keys(topics: tuple[RosTopic, ...]) -> list[str]:
    """Every key the bridge's node uses for ``topics`` (services/rmf_bridge/ros_keys.py), in
    both key formats, without and with a namespace, in two ROS domains."""
    return [
        ros_key(t, key_format, namespace, domain_id)
        for t in topics
        for key_format in KEY_FORMATS
        for namespace in ("", "/building1", "/site/b2")
        for domain_id in (0, 42)
    ]


def test_the_building_bridge_may_use_every_key_its_node_declares() -> None:
    for name in endpoints.PUBLISHES:  # the building's door and lift states, on wheelnav's keys
        assert allows("rmf_bridge", "publish", KEYS.key(name))
        assert allows("rmf_bridge", "publish", KEYS.key(name, **{name.split("_")[0]: "d1"}))
    for name in endpoints.SUBSCRIBES:  # the chair's door and lift requests
        assert allows("rmf_bridge", "read", KEYS.key(name))
    for key in building_keys(endpoints.ROS_PUBLISHES):  # the requests out to the building
        assert allows("rmf_bridge", "publish", key), key
    for key in building_keys(endpoints.ROS_SUBSCRIBES):  # the building's states in
        assert allows("rmf_bridge", "read", key), key
    assert allows("rmf_bridge", "publish", KEYS.key("diagnostics", service="rmf_bridge"))
    assert allows("rmf_bridge", "token", KEYS.key("alive", service="rmf_bridge"))


@pytest.mark.parametrize(
    ("key", "who_may"),
    [
        (KEYS.cmd_vel, "controller"),
        (KEYS.nav_goal, "alice"),
        (KEYS.estop, "alice"),
        (KEYS.key("door_request", door="d1"), "navigator"),
        (KEYS.key("diagnostics", service="navigator"), "navigator"),
        (KEYS.ack, "building"),
        (KEYS.key("building_bodies"), "building"),
    ],
)
def test_the_building_bridge_may_not_publish_what_others_may(key: str, who_may: str) -> None:
    assert allows(who_may, "publish", key)
    assert not allows("rmf_bridge", "publish", key)


def test_the_building_bridge_publishes_nothing_more_on_wheelnavs_keys() -> None:
    # a rule reaching any key of the table (pattern against pattern), beyond its own
    mine = {*endpoints.PUBLISHES, "diagnostics", "events"}
    bridge = [zenoh.KeyExpr(k) for k in R["rmf_bridge"]["publish"]]
    reached = {t.name for t in TOPICS if any(k.intersects(KEYS.key(t.name)) for k in bridge)}
    assert reached == mine
    assert set(R["rmf_bridge"]) == {"read", "publish", "token"}  # no query, no serve


def test_the_open_rmf_side_publishes_states_and_reads_requests_only() -> None:
    for key in building_keys(endpoints.ROS_SUBSCRIBES):
        assert allows("building-rmf", "publish", key) and not allows("rmf_bridge", "publish", key)
    for key in building_keys(endpoints.ROS_PUBLISHES):
        assert allows("building-rmf", "read", key)
        assert allows("rmf_bridge", "publish", key) and not allows("building-rmf", "publish", key)
    for name, who_may in (("door_state", "building"), ("cmd_vel", "controller")):
        assert allows(who_may, "publish", KEYS.key(name))
        assert not allows("building-rmf", "publish", KEYS.key(name))
    assert carried(RMF_HOSTS[-1], RMF_HOSTS) == []  # no identity: no password on its router


def test_no_open_rmf_rule_reaches_a_key_of_the_topic_table() -> None:
    # `**/door_states` would let the building forge `wheelnav/chair1/events/door_states`
    rmf = {k for t in ROS_TOPICS for k in key_patterns(t)}
    granted = {k for n in ("rmf_bridge", "building-rmf") for a in R[n].values() for k in a}
    assert {k for k in granted if not k.startswith("wheelnav/")} == rmf
    for key in rmf:
        reached = [t.name for t in TOPICS if zenoh.KeyExpr(key).intersects(KEYS.key(t.name))]
        assert reached == [], (key, reached)


def test_a_host_carrying_the_open_rmf_side_trusts_the_chairs_router_on_its_keys() -> None:
    # over its link come the chair's requests, and go the building's states
    trusted = upstream_keys(RMF_HOSTS[-1])
    assert trusted[0] == "wheelnav/**"
    assert {*R["building-rmf"]["publish"], *R["building-rmf"]["read"]} <= set(trusted)
    assert upstream_keys(Identity("laptop", HOST, ("@operators",))) == ["wheelnav/**"]
    with pytest.raises(ValueError, match="one of @operators, @viewers, @services, rmf"):
        carried(Identity("building-rmf", HOST, ("rmff",)), IDS)
