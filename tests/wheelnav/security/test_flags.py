"""Credential flags of the client commands and ``wheelnav up``'s one line on security."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from shared.config import ConfigError
from wheelnav.launcher.cli import secured_router, security_banner
from wheelnav.security import store
from wheelnav.topic_tools.cli import add_connect_argument, client_transport


def _args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    add_connect_argument(p)
    return p.parse_args(argv)


def test_without_flags_a_client_is_insecure(monkeypatch) -> None:
    monkeypatch.delenv("WHEELNAV_SECURITY", raising=False)
    transport = client_transport(_args([]))
    assert transport.security.dir == "" and transport.connect == ["tcp/127.0.0.1:7447"]


def test_security_and_user_come_from_flags_or_the_environment(tmp_path: Path, monkeypatch) -> None:
    args = _args(["--security", str(tmp_path), "--user", "alice"])
    assert client_transport(args).security.dir == str(tmp_path) and args.user == "alice"
    monkeypatch.setenv("WHEELNAV_SECURITY", str(tmp_path))
    monkeypatch.setenv("WHEELNAV_USER", "bob")
    args = _args([])
    assert client_transport(args).security.dir == str(tmp_path) and args.user == "bob"


def test_security_without_a_user_or_a_folder_is_one_line(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.delenv("WHEELNAV_USER", raising=False)
    with pytest.raises(ConfigError, match="--security needs --user NAME"):
        client_transport(_args(["--security", str(tmp_path)]))
    with pytest.raises(ConfigError, match="no such directory"):
        client_transport(_args(["--security", str(tmp_path / "no"), "--user", "a"]))


def test_up_says_insecure_in_one_line_or_how_it_is_secured() -> None:
    line = security_banner("tcp/127.0.0.1:7447", "", "chair1", 0)
    assert line.startswith("WARNING: insecure") and "\n" not in line
    assert "tcp/127.0.0.1:7447" in line and "docs/security.md" in line
    line = security_banner("tls/127.0.0.1:7447", "/keys", "chair1", 12)
    assert line.startswith("secured: mutual TLS") and "12 identities in /keys" in line


def test_a_secured_up_listens_on_tls_with_the_folders_rules(tmp_path: Path) -> None:
    store.init(tmp_path / "keys", "chair1", [], ["operator"], ["viewer"])
    folder, listen, access, identities = secured_router(
        str(tmp_path / "keys"), "tcp/0.0.0.0:7447", "chair2"
    )
    assert folder == str((tmp_path / "keys").resolve()) and listen == "tls/0.0.0.0:7447"
    assert access["default_permission"] == "deny" and identities == len(store.SERVICE_NAMES) + 2
    rules = [r for r in access["rules"] if r["id"] == "controller/publish/ingress"]
    assert "wheelnav/chair2/cmd_vel" in rules[0]["key_exprs"]  # the configured robot's keys
    with pytest.raises(ConfigError, match="not a credentials folder"):
        secured_router(str(tmp_path), "tcp/127.0.0.1:7447", "chair1")
    with pytest.raises(ConfigError, match="no such directory"):
        secured_router(str(tmp_path / "none"), "tcp/127.0.0.1:7447", "chair1")


def test_a_secured_link_is_made_by_a_hosts_router_not_the_chairs(tmp_path: Path) -> None:
    keys = tmp_path / "keys"
    store.init(keys, "chair1", ["10.77.1.1"], ["operator"], ["viewer"])
    store.add(keys, "building-host", "host", ("building",))
    links = ["tcp/10.77.1.1:7447"]
    with pytest.raises(ConfigError, match="made by another host's router, as a host identity"):
        secured_router(str(keys), "tcp/127.0.0.1:7447", "chair1", "router", links)
    _f, listen, access, admitted = secured_router(
        str(keys), "tcp/127.0.0.1:7447", "chair1", "building-host", links
    )
    assert listen == "tls/127.0.0.1:7447" and admitted == 1  # the building service
    assert "upstream" in {s["id"] for s in access["subjects"]}
    line = security_banner(listen, str(keys), "chair1", admitted, "building-host")
    assert "1 identities" in line and "this host's router as building-host" in line
