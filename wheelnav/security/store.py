"""A chair's credentials folder: written by ``wheelnav security init`` and ``add``, read by
``wheelnav up`` for the router's access control.

Layout (shared/credentials.py reads an identity's folder)::

    DIR/identities.json      robot, router hosts, identity -> role
    DIR/ca/ca.pem, ca.key    the certificate authority (ca.key only signs new identities)
    DIR/router/              ca.pem cert.pem key.pem passwords.txt zenoh.json5
    DIR/<identity>/          ca.pem cert.pem key.pem password zenoh.json5
    DIR/<host>/              the same and passwords.txt (its clients'): a host's router

Secrets (keys, passwords, the zenoh.json5 files that hold a password) are readable by
their owner only. The ``zenoh.json5`` files hold the same settings wheelnav builds at run
time (shared/credentials.py), with absolute paths, for other Zenoh tools (``zenohd -c
DIR/router/zenoh.json5``, a Zenoh client of another language).
"""

from __future__ import annotations

import json
import os
import secrets
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shared.config import ConfigError
from shared.credentials import (
    CA_FILE,
    CERT_FILE,
    KEY_FILE,
    PASSWORD_FILE,
    PASSWORDS_FILE,
    ROUTER,
    session_settings,
)
from shared.topics import TOPICS, check_name
from wheelnav.launcher.fleet import ROUTER_PORT, SERVICES
from wheelnav.security.acl import (
    HOST,
    OPERATOR,
    PERSON_ROLES,
    RMF,
    SERVICE,
    VIEWER,
    Identity,
    access_control,
    carried,
    grants,
    upstream_keys,
)
from wheelnav.security.pki import Issued, issue, new_ca

MANIFEST = "identities.json"
CA_DIR = "ca"
CA_KEY_FILE = "ca.key"
ZENOH_FILE = "zenoh.json5"
# the fleet's services, the rerun recorder (`up --rrd`) and the mission runner (it acks
# lockstep ticks and sends the scenario's goal)
SERVICE_NAMES = (*(s.name for s in SERVICES), "viz", "mission")
DEFAULT_HOSTS = ("localhost", "127.0.0.1", "::1")
RESERVED = (CA_DIR, ROUTER, RMF)  # RMF: a host's word for the Open-RMF building side
ROLES = (SERVICE, *PERSON_ROLES, HOST)


@dataclass(frozen=True)
class Written:
    """One thing written: the folder or file (relative to the root) and what it is for."""

    path: str
    what: str


@dataclass(frozen=True)
class Manifest:
    """What the folder holds: the chair, the router's host names, every identity (and, for
    a host, whose traffic its router carries)."""

    robot: str
    hosts: tuple[str, ...]
    identities: tuple[Identity, ...]

    def to_json(self) -> str:
        data: dict[str, Any] = {
            "robot": self.robot,
            "hosts": list(self.hosts),
            "identities": {i.name: i.role for i in self.identities},
        }
        carries = {i.name: list(i.carries) for i in self.identities if i.role == HOST}
        if carries:
            data["carries"] = carries
        return json.dumps(data, indent=2)

    def identity(self, name: str) -> Identity | None:
        return next((i for i in self.identities if i.name == name), None)


def load(root: str | Path) -> Manifest:
    """The manifest of credentials folder ``root``; ConfigError with one line if none."""
    path = Path(root) / MANIFEST
    if not path.is_file():
        raise ConfigError(f"{root}: not a credentials folder (no {MANIFEST}; see `security init`)")
    data = json.loads(path.read_text())
    carries = data.get("carries", {})
    ids = tuple(
        Identity(name, role, tuple(carries.get(name, ())))
        for name, role in data["identities"].items()
    )
    return Manifest(data["robot"], tuple(data["hosts"]), ids)


def router_access_control(manifest: Manifest, robot: str, identity: str = ROUTER) -> dict:
    """The access control for ``robot`` of the router of ``identity``, from the topic table
    and the identities: the chair's router (``router``) knows every identity; a host's
    router the identities it carries, and the chair's router it links to. ConfigError if
    ``identity`` is neither."""
    granted = grants(TOPICS, manifest.identities, robot)
    if identity == ROUTER:
        return access_control(granted)
    host = manifest.identity(identity)
    if host is None or host.role != HOST:
        raise ConfigError(
            f"{identity!r} is not a host of this credentials folder (make one with `wheelnav "
            f"security add DIR {identity} --role host --carries WHO`)"
        )
    clients = {n: granted[n] for n in carried(host, manifest.identities)}
    return access_control(clients, upstream_keys(host))


def check_identity(name: str, role: str, taken: set[str]) -> str:
    """A new identity's name; ValueError if invalid, taken, or a person or a host named as a
    service (a service's identity is its own name: one the fleet added since `init`)."""
    check_name(role, name)
    if role not in ROLES:
        raise ValueError(f"role {role!r}: use {', '.join(ROLES)}")
    if name in RESERVED or (role != SERVICE and name in SERVICE_NAMES):
        raise ValueError(f"{name!r} is a service's or a reserved name; choose another")
    if name in taken:
        raise ValueError(f"{name!r} already has credentials")
    return name


def init(
    root: str | Path,
    robot: str,
    hosts: list[str],
    operators: list[str],
    viewers: list[str],
) -> list[Written]:
    """Write a new credentials folder for one chair; ValueError if ``root`` is not empty."""
    root = Path(root)
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise ValueError(f"{root} exists and is not empty: choose a new folder (or `add`)")
    check_name("robot", robot)
    taken: set[str] = set(SERVICE_NAMES)
    people = []
    for role, names in ((OPERATOR, operators), (VIEWER, viewers)):
        for name in names:
            people.append(Identity(check_identity(name, role, taken), role))
            taken.add(name)
    ids = (*(Identity(n, SERVICE) for n in SERVICE_NAMES), *people)
    manifest = Manifest(robot, tuple(dict.fromkeys([*DEFAULT_HOSTS, *hosts])), ids)
    _mkdir(root)
    ca = new_ca(f"wheelnav {robot} CA")
    _mkdir(root / CA_DIR)
    _write(root / CA_DIR / CA_FILE, ca.cert_pem, secret=False)
    _write(root / CA_DIR / CA_KEY_FILE, ca.key_pem, secret=True)
    written = [Written(f"{CA_DIR}/", "certificate authority (ca.key signs new identities)")]
    passwords = {}
    for ident in ids:
        passwords[ident.name] = _write_identity(root, ca, manifest, ident)
        written.append(Written(f"{ident.name}/", _describe(ident)))
    _write_router(root, ca, manifest, passwords)
    written.insert(1, Written(f"{ROUTER}/", _router_text(manifest)))
    _write(root / MANIFEST, manifest.to_json().encode(), secret=False)
    written.append(Written(MANIFEST, "the chair, the router's host names, who is who"))
    return written


def add(root: str | Path, name: str, role: str, carries: tuple[str, ...] = ()) -> list[Written]:
    """Credentials for one more operator, viewer or service (one the fleet gained since
    `init`), or a host whose router ``carries`` the traffic of identities (names, or
    ``@operators``, ``@viewers``, ``@services``) and of the Open-RMF building side
    (``rmf``); the routers know them once restarted."""
    root = Path(root)
    manifest = load(root)
    check_identity(name, role, {i.name for i in manifest.identities})
    ident = Identity(name, role, tuple(carries))
    if role == HOST and not carries:
        raise ValueError(f"host {name!r}: say whose traffic its router carries (--carries)")
    if role != HOST and carries:
        raise ValueError(f"{name!r}: only a host's router carries others (--role host)")
    carried(ident, manifest.identities)  # a word that names nobody: ValueError
    key_path = root / CA_DIR / CA_KEY_FILE
    if not key_path.is_file():
        raise ValueError(f"{key_path} is missing: only the CA's key can sign a new identity")
    ca = Issued((root / CA_DIR / CA_FILE).read_bytes(), key_path.read_bytes())
    manifest = Manifest(manifest.robot, manifest.hosts, (*manifest.identities, ident))
    password = _write_identity(root, ca, manifest, ident)
    router = root / ROUTER
    with (router / PASSWORDS_FILE).open("a") as f:
        f.write(f"{name}:{password}\n")
    _write_router_config(root, manifest)
    hosts = [i for i in manifest.identities if i.role == HOST]
    for host in hosts:  # a new operator is let in by the hosts carrying @operators
        _write_host_config(root, manifest, host)
    _write(root / MANIFEST, manifest.to_json().encode(), secret=False)
    return [
        Written(f"{name}/", _describe(ident, manifest)),
        Written(f"{ROUTER}/{PASSWORDS_FILE}", f"{name} added"),
        Written(f"{ROUTER}/{ZENOH_FILE}", "access control with the new identity"),
        *(Written(f"{h.name}/", "the clients it lets in and their rules") for h in hosts),
        Written(MANIFEST, f"{name}: {role}"),
    ]


def _describe(ident: Identity, manifest: Manifest | None = None) -> str:
    if ident.role == HOST and manifest is not None:
        names = carried(ident, manifest.identities)
        names += ["the Open-RMF building side"] if RMF in ident.carries else []
        return f"host: its router links to the chair's, for {', '.join(names)}"
    return {
        SERVICE: "service",
        OPERATOR: "operator: may send goals, cancels, resumes, emergency stops",
        VIEWER: "viewer: may only read",
    }[ident.role]


def _router_text(manifest: Manifest) -> str:
    return (
        f"router: certificate for {', '.join(manifest.hosts)}; "
        f"{PASSWORDS_FILE} ({len(manifest.identities)} users); {ZENOH_FILE} (for zenohd)"
    )


def _write_identity(root: Path, ca: Issued, manifest: Manifest, ident: Identity) -> str:
    """Write ``ident``'s folder; returns its password."""
    folder = root / ident.name
    _mkdir(folder)
    # a host's router is reached by its own clients on loopback: a server's certificate
    leaf = issue(ca, ident.name, DEFAULT_HOSTS if ident.role == HOST else ())
    password = secrets.token_urlsafe(24)
    _write(folder / CA_FILE, ca.cert_pem, secret=False)
    _write(folder / CERT_FILE, leaf.cert_pem, secret=False)
    _write(folder / KEY_FILE, leaf.key_pem, secret=True)
    _write(folder / PASSWORD_FILE, (password + "\n").encode(), secret=True)
    if ident.role == HOST:
        return password  # its dictionary and config: _write_host_config, once it is known
    connect = f"tls/{_url_host(_reached_at(manifest.hosts))}:{ROUTER_PORT}"
    settings = session_settings(folder.resolve(), ident.name, router=False, password=password)
    conf = {"mode": "client", "connect/endpoints": [connect], **settings}
    _write(folder / ZENOH_FILE, _json5(conf, f"{ident.name} ({ident.role})"), secret=True)
    return password


def _write_router(root: Path, ca: Issued, manifest: Manifest, passwords: dict[str, str]) -> None:
    folder = root / ROUTER
    _mkdir(folder)
    leaf = issue(ca, ROUTER, manifest.hosts)
    _write(folder / CA_FILE, ca.cert_pem, secret=False)
    _write(folder / CERT_FILE, leaf.cert_pem, secret=False)
    _write(folder / KEY_FILE, leaf.key_pem, secret=True)
    lines = "".join(f"{name}:{pw}\n" for name, pw in passwords.items())
    _write(folder / PASSWORDS_FILE, lines.encode(), secret=True)
    _write_router_config(root, manifest)


def _write_router_config(root: Path, manifest: Manifest) -> None:
    folder = root / ROUTER
    conf: dict[str, Any] = {
        "mode": "router",
        "listen/endpoints": [f"tls/0.0.0.0:{ROUTER_PORT}"],
        "scouting/multicast/enabled": False,
        **session_settings(folder.resolve(), ROUTER, router=True),
        "access_control": router_access_control(manifest, manifest.robot),
    }
    _write(folder / ZENOH_FILE, _json5(conf, f"the router of {manifest.robot}"), secret=False)


def _write_host_config(root: Path, manifest: Manifest, host: Identity) -> None:
    """A host's dictionary (the passwords of the identities it carries, from the chair's)
    and its router config: listening on loopback, linked to the chair's router."""
    folder = root / host.name
    names = set(carried(host, manifest.identities))
    lines = (root / ROUTER / PASSWORDS_FILE).read_text().splitlines(keepends=True)
    mine = "".join(ln for ln in lines if ln.split(":", 1)[0] in names)
    _write(folder / PASSWORDS_FILE, mine.encode(), secret=True)
    password = (folder / PASSWORD_FILE).read_text().strip()
    conf: dict[str, Any] = {
        "mode": "router",
        "listen/endpoints": [f"tls/127.0.0.1:{ROUTER_PORT}"],
        "connect/endpoints": [f"tls/{_url_host(_reached_at(manifest.hosts))}:{ROUTER_PORT}"],
        "scouting/multicast/enabled": False,
        **session_settings(folder.resolve(), host.name, router=True, password=password),
        "access_control": router_access_control(manifest, manifest.robot, host.name),
    }
    _write(folder / ZENOH_FILE, _json5(conf, f"the router of host {host.name}"), secret=True)


def _reached_at(hosts: tuple[str, ...]) -> str:
    """Where a client's zenoh.json5 connects: the chair's first network name, else loopback."""
    return next((h for h in hosts if h not in DEFAULT_HOSTS), "127.0.0.1")


def _url_host(host: str) -> str:
    return f"[{host}]" if ":" in host else host


def _json5(flat: dict[str, Any], who: str) -> bytes:
    """A Zenoh config file from ``path -> value`` entries (JSON is valid JSON5)."""
    nested: dict[str, Any] = {}
    for path, value in flat.items():
        *parents, leaf = path.split("/")
        node = nested
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    head = f"// Zenoh config of {who}, written by `wheelnav security`.\n"
    return (head + json.dumps(nested, indent=2) + "\n").encode()


def _mkdir(path: Path) -> None:
    path.mkdir(mode=0o700, parents=True, exist_ok=True)


def _write(path: Path, data: bytes, secret: bool) -> None:
    """Write ``data``; a secret is created readable by its owner only (never world-readable
    for a moment)."""
    mode = 0o600 if secret else 0o644
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.chmod(path, mode)
