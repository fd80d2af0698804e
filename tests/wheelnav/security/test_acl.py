"""The router's rules derived from the topic table: who may publish, query, serve, hold."""

from __future__ import annotations

import pytest

from shared.topics import TOPICS, Topic
from wheelnav.security.acl import (
    HOST,
    OPERATOR,
    SERVICE,
    VIEWER,
    Identity,
    access_control,
    carried,
    grants,
    phrases,
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
    assert all(G[n]["read"] == ["wheelnav/**"] for n in G)


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
        ("controller/publish/ingress", ["ingress"], ["put"])
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
    acl = access_control({"alice": G["alice"]}, upstream=True)
    (up,) = [s for s in acl["subjects"] if s["id"] == "upstream"]
    assert up == {"id": "upstream", "cert_common_names": ["router"]}  # no username: it accepts
    (rule,) = [r for r in acl["rules"] if r["id"] == "upstream"]
    assert rule["key_exprs"] == ["wheelnav/**"] and set(rule["flows"]) == {"ingress", "egress"}
    assert {"put", "query", "reply", "declare_queryable"} <= set(rule["messages"])
    assert "upstream" not in str(access_control({"alice": G["alice"]}))
