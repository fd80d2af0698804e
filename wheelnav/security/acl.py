"""The router's access control, derived from the topic table (shared/topics.py).

Who may do what is read from each row's publisher column (and, for a query, its
subscriber column: the queryables), so a new topic needs no hand-written rule, only its
publishers named in words this module knows (:data:`PHRASES`; an unknown word fails with
the topic and the word). Two pure steps:

- :func:`grants`: identity -> action -> keys, e.g. the controller may ``publish`` on
  ``wheelnav/chair1/cmd_vel``; every identity may ``read`` ``wheelnav/**``.
- :func:`access_control`: those grants as Zenoh 1.x ``access_control`` config, deny by
  default; a subject per identity binds its certificate's common name to its username.

A host (the router of another machine: a building server, a laptop) links to the chair's
router and carries the traffic of the identities that run there: the chair's router lets
it do what those identities may do, no more (a laptop's router carrying operators and
viewers cannot forward a velocity). The host's own router enforces the same rules on its
clients and trusts the chair's router, which it reaches (:func:`access_control` with
``upstream``).

A field ``{service}`` or ``{source}`` of the key is the identity's own name where it
offers (publishes, holds a token, answers queries): a service publishes its diagnostics
and holds its liveliness token on its own key only.

The building bridge to Open-RMF (``rmf_bridge``) has rights the table cannot give
(:func:`open_rmf`): it stands in for the building emulator on door and lift states, and it
speaks Open-RMF's topics, outside ``wheelnav/**``. The building's own side of those topics
(its zenoh-bridge-ros2dds or rmw_zenohd) links to the chair's router as a host carrying
:data:`RMF`.
"""

from __future__ import annotations

import re
import string
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from services.rmf_bridge import endpoints as bridge
from services.rmf_bridge.ros_keys import TOPICS as ROS_TOPICS
from services.rmf_bridge.ros_keys import RosTopic, key_patterns
from shared.credentials import ROUTER
from shared.topics import ROOT, Keys, Topic

SERVICE, OPERATOR, VIEWER, HOST = "service", "operator", "viewer", "host"
PERSON_ROLES = (OPERATOR, VIEWER)
GROUPS = {"@operators": OPERATOR, "@viewers": VIEWER, "@services": SERVICE}
# a host's word for the Open-RMF building side it carries: no identity, rights of its own
RMF = "rmf"

# Who the words of the table's publisher / queryable columns mean: service names, or a
# group: "@operators" (people allowed to command the chair), "@services" (every service
# identity), "@servers" (the services that answer this row's query themselves).
PHRASES: dict[str, tuple[str, ...]] = {
    "sim": ("sim",),
    "building": ("building",),
    "localisation": ("localisation",),
    "planner": ("planner",),
    "controller": ("controller",),
    "navigator": ("navigator",),
    "driver": ("driver",),
    "chair driver": ("driver", "vlp16_driver"),
    "mission": ("mission",),
    "mission runner": ("mission",),
    "user": ("@operators",),
    "wheelnav stop": ("@operators",),
    "any service": ("@services",),
    "every service": ("@services",),
    "a (re)starting holder": ("@servers",),
}

# action -> (flow, Zenoh message kinds) it needs, as the router sees them: a publisher's
# puts come in, and it hears of the subscribers (a client or a router that hears of none
# sends nothing; on wheelnav/** reading grants this too, on Open-RMF's keys only this); a
# reader's subscriptions come in, samples and tokens go out; a querier's query comes in,
# replies go out; a queryable the reverse. Readers also hear of the others' subscriptions:
# a refused client's puts should reach the router and be refused there, not rest on the
# client's goodwill.
ACTIONS: dict[str, tuple[tuple[str, tuple[str, ...]], ...]] = {
    "publish": (("ingress", ("put",)), ("egress", ("declare_subscriber",))),
    "token": (("ingress", ("liveliness_token",)),),
    "query": (("ingress", ("query",)), ("egress", ("reply",))),
    "serve": (("ingress", ("declare_queryable", "reply")), ("egress", ("query",))),
    "read": (
        ("ingress", ("declare_subscriber", "declare_liveliness_subscriber", "liveliness_query")),
        ("egress", ("put", "liveliness_token", "declare_subscriber")),
    ),
    # a host's router: it forwards its clients' queries only to the queryables it heard of
    "route": (("egress", ("declare_queryable",)),),
}
UPSTREAM = "upstream"  # a host router's rule for the chair's router, which it links to
OWN_FIELDS = ("service", "source")
_QUALIFIER = re.compile(r"\s*\([^()]*\)$")  # a trailing "(get)", "(queryable)", ...
_SEPARATOR = re.compile(r"\s*[,/]\s*(?![^()]*\))")  # "," or "/" outside parentheses


@dataclass(frozen=True)
class Identity:
    """One holder of credentials: a service (by its name), an operator, a viewer, or a host
    whose router ``carries`` the traffic of identities (names, or :data:`GROUPS`)."""

    name: str
    role: str
    carries: tuple[str, ...] = ()


Grants = dict[str, dict[str, list[str]]]


def phrases(column: str) -> list[str]:
    """The words of a table column: ``"navigator, user (get)"`` -> navigator, user."""
    return [_QUALIFIER.sub("", p).strip() for p in _SEPARATOR.split(column) if p.strip()]


def who(topic: Topic, column: str, identities: Iterable[Identity]) -> list[str]:
    """The identities that ``column`` (a column of ``topic``'s row) names, in table order.

    ValueError naming the topic and the word for a word :data:`PHRASES` does not know.
    """
    ids = list(identities)
    groups = {
        "@operators": [i.name for i in ids if i.role == OPERATOR],
        "@services": [i.name for i in ids if i.role == SERVICE],
    }
    known = {i.name for i in ids}
    out: list[str] = []
    for phrase in phrases(column):
        if phrase not in PHRASES:
            raise ValueError(
                f"topic {topic.name!r}: who is {phrase!r}? name it in wheelnav/security/acl.py "
                "PHRASES"
            )
        for name in PHRASES[phrase]:
            if name == "@servers" and column is not topic.subscribers:
                members = who(topic, topic.subscribers, ids)
            elif name == "@servers":
                raise ValueError(f"topic {topic.name!r}: {phrase!r} in the queryable column")
            else:
                members = groups.get(name, [name] if name in known else [])
            out += [m for m in members if m not in out]
    return out


def topic_key(keys: Keys, topic: Topic, owner: str | None) -> str:
    """``topic``'s key; ``{service}``/``{source}`` is ``owner`` (None: any), others any."""
    fields = {f for _, f, _, _ in string.Formatter().parse(topic.pattern) if f}
    parts = {f: owner for f in OWN_FIELDS if f in fields and owner is not None}
    return keys.key(topic.name, **parts)


def grants(topics: Iterable[Topic], identities: Iterable[Identity], robot: str) -> Grants:
    """identity -> action (:data:`ACTIONS`) -> sorted keys, for one robot's router; the
    building bridge's beyond the table (:func:`open_rmf`); a host's are those of the
    identities it carries (and the Open-RMF side's, :data:`RMF`), and ``route`` for what
    they query."""
    ids = list(identities)
    keys = Keys(robot)
    out: Grants = {i.name: {"read": [f"{ROOT}/**"]} for i in ids}

    def allow(name: str, action: str, key: str) -> None:
        held = out[name].setdefault(action, [])
        if key not in held:
            held.append(key)

    def allow_all(name: str, actions: Mapping[str, list[str]]) -> None:
        for action, keys_ in actions.items():
            for key in keys_:
                allow(name, action, key)

    for topic in topics:
        if topic.kind == "query":
            for name in who(topic, topic.publisher, ids):
                allow(name, "query", topic_key(keys, topic, None))
            for name in who(topic, topic.subscribers, ids):
                allow(name, "serve", topic_key(keys, topic, name))
        else:
            action = "token" if topic.kind == "liveliness" else "publish"
            for name in who(topic, topic.publisher, ids):
                allow(name, action, topic_key(keys, topic, name))
    rmf = open_rmf(keys)
    if any(i.name == bridge.NAME and i.role == SERVICE for i in ids):
        allow_all(bridge.NAME, rmf[bridge.NAME])
    for host in (i for i in ids if i.role == HOST):
        for name in carried(host, ids):
            allow_all(host.name, out[name])
        if RMF in host.carries:
            allow_all(host.name, rmf[RMF])
        for key in out[host.name].get("query", []):
            allow(host.name, "route", key)
    return {name: {a: sorted(k) for a, k in acts.items()} for name, acts in out.items()}


def open_rmf(keys: Keys) -> Grants:
    """What the building bridge and the Open-RMF building side (:data:`RMF`) may do beyond
    the topic table: the bridge publishes door and lift states in the emulator's stead and
    the chair's requests on Open-RMF's keys, and reads the building's states there; the
    building side publishes those states and reads those requests (services/rmf_bridge/
    endpoints.py). Open-RMF's keys in both key formats, in any domain and namespace (up to
    two levels for zenoh-bridge-ros2dds: ros_keys.key_patterns): the rules are made from
    the credentials folder, without the fleet config that names them."""
    states = _patterns(bridge.ROS_SUBSCRIBES)
    requests = _patterns(bridge.ROS_PUBLISHES)
    ours = [keys.key(name) for name in bridge.PUBLISHES]
    return {
        bridge.NAME: {"publish": [*ours, *requests], "read": states},
        RMF: {"publish": states, "read": requests},
    }


def upstream_keys(host: Identity) -> list[str]:
    """Where ``host``'s router trusts the chair's router it links to: ``wheelnav/**``, and
    Open-RMF's keys when it carries the building side (the chair's requests come in over
    that link, the building's states go out)."""
    rmf = _patterns(ROS_TOPICS) if RMF in host.carries else []
    return [f"{ROOT}/**", *rmf]


def _patterns(topics: Iterable[RosTopic]) -> list[str]:
    return [key for t in topics for key in key_patterns(t)]


def carried(host: Identity, identities: Iterable[Identity]) -> list[str]:
    """The identities whose traffic ``host``'s router carries: its words, each an identity
    name or a group of :data:`GROUPS` (:data:`RMF`, the Open-RMF side, is none: skipped);
    ValueError naming a word that is neither."""
    ids = [i for i in identities if i.role != HOST]
    out: list[str] = []
    for word in host.carries:
        if word == RMF:
            continue
        if word in GROUPS:
            names = [i.name for i in ids if i.role == GROUPS[word]]
        elif word in {i.name for i in ids}:
            names = [word]
        else:
            raise ValueError(
                f"host {host.name!r} carries {word!r}: neither an identity nor one of "
                f"{', '.join([*GROUPS, RMF])}"
            )
        out += [n for n in names if n not in out]
    return out


def access_control(
    granted: Mapping[str, Mapping[str, list[str]]], upstream: Sequence[str] = ()
) -> dict:
    """Zenoh ``access_control`` config for ``granted``: deny by default; per identity a
    subject (certificate common name and username, both its name) and a policy.

    ``upstream``: the config of a host's router, which links to the chair's router and
    lets it do anything on these key expressions (:func:`upstream_keys`: it is the
    chair's, and enforces the rules of its own clients). That router is known by its
    certificate's common name alone: the side that accepts a link gives no username.
    """
    rules: list[dict] = []
    policies: list[dict] = []
    subjects = [{"id": name, "cert_common_names": [name], "usernames": [name]} for name in granted]
    if upstream:
        kinds = sorted({m for flows in ACTIONS.values() for _, ms in flows for m in ms})
        rule = {"id": UPSTREAM, "permission": "allow", "flows": ["ingress", "egress"]}
        rules.append({**rule, "messages": kinds, "key_exprs": list(upstream)})
        subjects.append({"id": UPSTREAM, "cert_common_names": [ROUTER]})
        policies.append({"id": UPSTREAM, "rules": [UPSTREAM], "subjects": [UPSTREAM]})
    for name, actions in granted.items():
        own = [
            rule
            for action, keys in actions.items()
            if keys
            for rule in _rules(f"{name}/{action}", action, keys)
        ]
        rules += own
        policies.append({"id": name, "rules": [r["id"] for r in own], "subjects": [name]})
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }


def _rules(prefix: str, action: str, keys: list[str]) -> list[dict]:
    return [
        {
            "id": f"{prefix}/{flow}",
            "permission": "allow",
            "flows": [flow],
            "messages": list(messages),
            "key_exprs": list(keys),
        }
        for flow, messages in ACTIONS[action]
    ]
