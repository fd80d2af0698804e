"""A secured session's Zenoh settings from a credentials folder, and the config key."""

from __future__ import annotations

from pathlib import Path

import pytest

from shared import config as config_mod
from shared.config import ConfigError, SecurityConfig, TransportConfig
from shared.credentials import read_settings, secure_endpoint, session_settings
from shared.transport import zenoh_config


def test_endpoints_move_to_tls_and_other_protocols_are_refused() -> None:
    assert secure_endpoint("tcp/127.0.0.1:7447") == "tls/127.0.0.1:7447"
    assert secure_endpoint("tls/chair1.local:7447") == "tls/chair1.local:7447"
    with pytest.raises(ConfigError, match="'udp/1.2.3.4:5': a secured session runs on tls"):
        secure_endpoint("udp/1.2.3.4:5")


def test_a_client_presents_its_certificate_and_password_a_router_checks_both() -> None:
    client = session_settings(Path("/c/alice"), "alice", router=False, password="pw")
    assert client["transport/link/protocols"] == ["tls"]
    assert client["transport/link/tls/enable_mtls"] is True
    assert client["transport/link/tls/connect_certificate"] == "/c/alice/cert.pem"
    assert client["transport/auth/usrpwd/user"] == "alice"
    assert client["transport/auth/usrpwd/password"] == "pw"
    router = session_settings(Path("/c/router"), "router", router=True)
    assert router["transport/link/tls/listen_private_key"] == "/c/router/key.pem"
    assert router["transport/auth/usrpwd/dictionary_file"] == "/c/router/passwords.txt"
    assert not any("usrpwd/user" in k for k in router)


def test_missing_credentials_fail_with_one_line(tmp_path: Path) -> None:
    (tmp_path / "alice").mkdir()
    (tmp_path / "alice" / "password").write_text("pw\n")
    (tmp_path / "router").mkdir()  # not a client: not offered
    with pytest.raises(ConfigError, match=r"no credentials for 'bob' in .* \(known: alice\)"):
        read_settings(tmp_path, "bob", router=False)
    with pytest.raises(ConfigError, match=r"credentials of 'alice': .*ca.pem is missing"):
        read_settings(tmp_path, "alice", router=False)
    with pytest.raises(ConfigError, match="no identity given"):
        read_settings(tmp_path, "", router=False)


def test_a_secured_transport_is_a_client_or_the_router(tmp_path: Path) -> None:
    peer = TransportConfig(mode="peer", security=SecurityConfig(dir=str(tmp_path)))
    with pytest.raises(ConfigError, match="a secured session is a client or the router"):
        zenoh_config(peer, "alice")


def test_the_config_key_names_an_existing_folder(tmp_path: Path) -> None:
    assert config_mod.load().transport.security.dir == ""
    cfg = config_mod.load(overrides=[f"transport.security.dir={tmp_path}"])
    assert cfg.transport.security.dir == str(tmp_path)
    with pytest.raises(ConfigError, match="transport.security.dir: no such directory"):
        config_mod.load(overrides=[f"transport.security.dir={tmp_path / 'nope'}"])
