"""Secured Zenoh sessions: what one needs from a credentials folder, as Zenoh settings.

``wheelnav security init DIR`` writes one folder per identity (a service, an operator, a
viewer, the router), each enough on its own to join the fleet::

    DIR/<identity>/ca.pem      the chair's certificate authority (to check the other side)
    DIR/<identity>/cert.pem    this identity's certificate (common name = identity)
    DIR/<identity>/key.pem     its private key
    DIR/<identity>/password    its Zenoh user/password secret (username = identity)
    DIR/router/passwords.txt   the router's user:password dictionary (instead of password)
    DIR/<host>/                a host's router (``--role host``): password and passwords.txt

A host's router listens for the clients of its host and links to the chair's router as
its identity, so it holds both: the dictionary of its clients and its own password.

:func:`session_settings` turns a folder into the Zenoh config entries of a mutual-TLS,
user/password session (pure, so the same entries are written to the ``zenoh.json5`` files
for other Zenoh tools); :func:`read_settings` checks the files and reads the secret.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from shared.config import ConfigError

CA_FILE = "ca.pem"
CERT_FILE = "cert.pem"
KEY_FILE = "key.pem"
PASSWORD_FILE = "password"
PASSWORDS_FILE = "passwords.txt"
ROUTER = "router"
SECURE_PROTOCOL = "tls"


def secure_endpoint(endpoint: str) -> str:
    """``endpoint`` on TLS: ``tcp/H:P`` becomes ``tls/H:P``; ConfigError for other protocols."""
    protocol, sep, address = endpoint.partition("/")
    if not sep or protocol not in ("tcp", SECURE_PROTOCOL):
        raise ConfigError(f"endpoint {endpoint!r}: a secured session runs on tls/HOST:PORT")
    return f"{SECURE_PROTOCOL}/{address}"


def session_settings(folder: Path, identity: str, router: bool, password: str = "") -> dict:
    """Zenoh config entries (``path -> value``) of a secured session from ``folder``.

    Both sides present a certificate of the chair's CA (mutual TLS) and only TLS links are
    accepted; a client also authenticates with user ``identity`` and ``password``, a router
    checks clients against its dictionary, and a router given a ``password`` (a host's,
    linking to the chair's router) authenticates as a client does. Who may do what is the
    routers' access control.
    """
    tls = "transport/link/tls"
    settings: dict[str, Any] = {
        "transport/link/protocols": [SECURE_PROTOCOL],
        f"{tls}/root_ca_certificate": str(folder / CA_FILE),
        f"{tls}/enable_mtls": True,
    }
    if router:
        settings[f"{tls}/listen_certificate"] = str(folder / CERT_FILE)
        settings[f"{tls}/listen_private_key"] = str(folder / KEY_FILE)
        settings["transport/auth/usrpwd/dictionary_file"] = str(folder / PASSWORDS_FILE)
    if not router or password:
        settings[f"{tls}/connect_certificate"] = str(folder / CERT_FILE)
        settings[f"{tls}/connect_private_key"] = str(folder / KEY_FILE)
        settings["transport/auth/usrpwd/user"] = identity
        settings["transport/auth/usrpwd/password"] = password
    return settings


def read_settings(
    root: str | Path, identity: str, router: bool, links: bool = False
) -> dict[str, Any]:
    """:func:`session_settings` for ``identity`` in credentials folder ``root``; a router
    that ``links`` to another authenticates to it with its own password.

    ConfigError with one line when the identity has no folder or a file is missing.
    """
    if not identity:
        raise ConfigError(f"secured session on {root}: no identity given (e.g. --user operator)")
    folder = Path(root).resolve() / identity
    secrets = [PASSWORDS_FILE] if router else []
    secrets += [PASSWORD_FILE] if links or not router else []
    if not folder.is_dir():
        known = sorted(p.parent.name for p in Path(root).glob(f"*/{PASSWORD_FILE}"))
        raise ConfigError(
            f"no credentials for {identity!r} in {root} (known: {', '.join(known) or 'none'}); "
            "make them with `wheelnav security init` or `wheelnav security add`"
        )
    for name in (CA_FILE, CERT_FILE, KEY_FILE, *secrets):
        if not (folder / name).is_file():
            raise ConfigError(f"credentials of {identity!r}: {folder / name} is missing")
    password = (folder / PASSWORD_FILE).read_text().strip() if PASSWORD_FILE in secrets else ""
    return session_settings(folder, identity, router, password)
