"""``wheelnav security init | add | show``: the credentials folder of one chair."""

from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest
from cryptography import x509

from shared.credentials import read_settings
from wheelnav.cli import main
from wheelnav.security import store
from wheelnav.security.pki import common_name


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("creds") / "chair1"
    store.init(root, "chair1", ["chair1.local", "192.168.1.20"], ["alice"], ["bob"])
    return root


def _cert(path: Path) -> x509.Certificate:
    return x509.load_pem_x509_certificate(path.read_bytes())


def test_init_writes_a_folder_per_identity_signed_by_one_ca(folder: Path) -> None:
    ca = _cert(folder / "ca" / "ca.pem")
    for name in (*store.SERVICE_NAMES, "alice", "bob", "router"):
        cert = _cert(folder / name / "cert.pem")
        cert.verify_directly_issued_by(ca)  # raises if not
        assert common_name((folder / name / "cert.pem").read_bytes()) == name
        assert (folder / name / "ca.pem").read_bytes() == (folder / "ca" / "ca.pem").read_bytes()
    manifest = store.load(folder)
    assert manifest.robot == "chair1"
    roles = {i.name: i.role for i in manifest.identities}
    assert roles["alice"] == "operator" and roles["bob"] == "viewer"
    assert roles["controller"] == "service"


def test_the_router_is_reached_by_the_names_given_and_by_loopback(folder: Path) -> None:
    san = _cert(folder / "router" / "cert.pem").extensions.get_extension_for_class(
        x509.SubjectAlternativeName
    )
    assert set(san.value.get_values_for_type(x509.DNSName)) == {"localhost", "chair1.local"}
    assert {str(a) for a in san.value.get_values_for_type(x509.IPAddress)} == {
        "127.0.0.1",
        "::1",
        "192.168.1.20",
    }


def test_secrets_are_readable_by_their_owner_only(folder: Path) -> None:
    for path in (
        folder / "ca" / "ca.key",
        folder / "alice" / "key.pem",
        folder / "alice" / "password",
        folder / "alice" / "zenoh.json5",
        folder / "router" / "passwords.txt",
    ):
        assert stat.S_IMODE(path.stat().st_mode) == 0o600, path


def test_the_router_knows_every_password(folder: Path) -> None:
    lines = (folder / "router" / "passwords.txt").read_text().splitlines()
    dictionary = dict(line.split(":", 1) for line in lines)
    assert dictionary["alice"] == (folder / "alice" / "password").read_text().strip()
    assert len(dictionary) == len(store.load(folder).identities)


def test_the_zenoh_configs_hold_what_wheelnav_uses(folder: Path) -> None:
    text = (folder / "alice" / "zenoh.json5").read_text()
    conf = json.loads(text.split("\n", 1)[1])
    assert conf["connect"]["endpoints"] == ["tls/chair1.local:7447"]
    assert conf["transport"]["auth"]["usrpwd"]["user"] == "alice"
    settings = read_settings(folder, "alice", router=False)
    tls = conf["transport"]["link"]["tls"]
    assert tls["connect_certificate"] == settings["transport/link/tls/connect_certificate"]
    router = json.loads((folder / "router" / "zenoh.json5").read_text().split("\n", 1)[1])
    assert router["access_control"]["default_permission"] == "deny"
    assert router["transport"]["link"]["tls"]["enable_mtls"] is True


def test_init_refuses_a_folder_that_is_not_empty(folder: Path) -> None:
    with pytest.raises(ValueError, match="not empty"):
        store.init(folder, "chair1", [], ["operator"], [])


@pytest.mark.parametrize(
    ("name", "why"),
    [("controller", "a service's"), ("router", "a service's"), ("a b", "use letters")],
)
def test_a_person_cannot_take_a_service_name_or_a_bad_one(
    tmp_path: Path, name: str, why: str
) -> None:
    with pytest.raises(ValueError, match=why):
        store.init(tmp_path / "x", "chair1", [], [name], [])


def test_add_an_operator_then_show_what_they_may_do(tmp_path: Path, capsys) -> None:
    root = tmp_path / "chair"
    assert main(["security", "init", str(root)]) == 0
    out = capsys.readouterr().out
    assert f"{root}/router/" in out and "wheelnav up --security" in out
    assert main(["security", "add", str(root), "carol", "--role", "operator"]) == 0
    assert "restart `wheelnav up`" in capsys.readouterr().out
    assert common_name((root / "carol" / "cert.pem").read_bytes()) == "carol"
    assert "carol:" in (root / "router" / "passwords.txt").read_text()
    acl = (root / "router" / "zenoh.json5").read_text()
    assert '"carol"' in acl
    assert main(["security", "add", str(root), "carol"]) == 2
    assert "already has credentials" in capsys.readouterr().out
    assert main(["security", "show", str(root)]) == 0
    shown = capsys.readouterr().out
    carol = shown.split("carol (operator)\n")[1]
    assert "publish" in carol and "wheelnav/chair1/nav/goal" in carol
    assert "viewer (viewer)\n" in shown


def test_a_hosts_router_gets_a_folder_to_link_to_the_chairs_and_let_its_clients_in(
    tmp_path: Path, capsys
) -> None:
    root = tmp_path / "chair"
    store.init(root, "chair1", ["10.77.2.1"], ["alice"], ["bob"])
    argv = ["security", "add", str(root), "laptop", "--role", "host"]
    assert main([*argv, "--carries", "@operators,@viewers"]) == 0
    assert "host: its router links to the chair's, for alice, bob" in capsys.readouterr().out
    laptop = root / "laptop"
    san = _cert(laptop / "cert.pem").extensions.get_extension_for_class(x509.SubjectAlternativeName)
    assert "localhost" in san.value.get_values_for_type(x509.DNSName)  # its clients reach it
    dictionary = (laptop / "passwords.txt").read_text()
    assert sorted(line.split(":")[0] for line in dictionary.splitlines()) == ["alice", "bob"]
    assert "laptop:" in (root / "router" / "passwords.txt").read_text()
    assert store.load(root).identity("laptop").carries == ("@operators", "@viewers")
    settings = read_settings(root, "laptop", router=True, links=True)
    assert settings["transport/auth/usrpwd/user"] == "laptop"
    assert settings["transport/auth/usrpwd/dictionary_file"].endswith("laptop/passwords.txt")
    conf = json.loads((laptop / "zenoh.json5").read_text().split("\n", 1)[1])
    assert conf["connect"]["endpoints"] == ["tls/10.77.2.1:7447"] and conf["mode"] == "router"
    subjects = {s["id"] for s in conf["access_control"]["subjects"]}
    assert subjects == {"alice", "bob", "upstream"}
    assert stat.S_IMODE((laptop / "zenoh.json5").stat().st_mode) == 0o600  # its password

    # an operator added later is let in by the host carrying @operators, not by another
    assert main([*argv[:3], "building-host", "--role", "host", "--carries", "building"]) == 0
    assert main(["security", "add", str(root), "carol"]) == 0
    assert "carol:" in (laptop / "passwords.txt").read_text()
    assert "carol:" not in (root / "building-host" / "passwords.txt").read_text()
    assert main(["security", "show", str(root)]) == 0
    assert "laptop (host, carries @operators, @viewers)" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("role", "carries", "why"),
    [
        ("host", (), "say whose traffic"),
        ("operator", ("building",), "only a host's router carries"),
        ("host", ("nobody",), "carries 'nobody': neither"),
        ("host", ("@admins",), "carries '@admins': neither"),
    ],
)
def test_a_host_says_whom_it_carries_and_only_a_host_does(
    tmp_path: Path, role: str, carries: tuple[str, ...], why: str
) -> None:
    store.init(tmp_path / "k", "chair1", [], ["alice"], [])
    with pytest.raises(ValueError, match=why):
        store.add(tmp_path / "k", "laptop", role, carries)
    assert not (tmp_path / "k" / "laptop").exists()


def test_only_a_host_of_the_folder_has_a_hosts_rules(tmp_path: Path) -> None:
    store.init(tmp_path / "k", "chair1", [], ["alice"], [])
    store.add(tmp_path / "k", "building-host", "host", ("building",))
    manifest = store.load(tmp_path / "k")
    acl = store.router_access_control(manifest, "chair1", "building-host")
    assert {s["id"] for s in acl["subjects"]} == {"building", "upstream"}
    chair = store.router_access_control(manifest, "chair1")
    assert "building-host" in {s["id"] for s in chair["subjects"]}
    with pytest.raises(ValueError, match="'alice' is not a host"):
        store.router_access_control(manifest, "chair1", "alice")


def test_the_open_rmf_building_side_links_as_a_host_carrying_rmf(tmp_path: Path, capsys) -> None:
    root = tmp_path / "chair"
    store.init(root, "chair1", ["10.77.3.1"], ["alice"], [])
    argv = ["security", "add", str(root), "building-rmf", "--role", "host", "--carries", "rmf"]
    assert main(argv) == 0
    assert "for the Open-RMF building side" in capsys.readouterr().out
    folder = root / "building-rmf"
    assert (folder / "passwords.txt").read_text() == ""  # it carries no identity of ours
    conf = json.loads((folder / "zenoh.json5").read_text().split("\n", 1)[1])
    assert conf["connect"]["endpoints"] == ["tls/10.77.3.1:7447"]
    acl = conf["access_control"]
    assert {s["id"] for s in acl["subjects"]} == {"upstream"}
    (up,) = [r for r in acl["rules"] if r["id"] == "upstream"]
    assert {"wheelnav/**", "adapter_door_requests", "*/door_states"} <= set(up["key_exprs"])
    chair = store.router_access_control(store.load(root), "chair1")
    rules = {r["id"]: r for r in chair["rules"]}
    assert "*/lift_states" in rules["building-rmf/publish/ingress"]["key_exprs"]
    assert "*/lift_states" in rules["rmf_bridge/read/ingress"]["key_exprs"]
    assert main(["security", "show", str(root)]) == 0
    shown = capsys.readouterr().out.split("building-rmf (host, carries rmf)\n")[1]
    assert "  publish  */**/door_states/" in shown and ", lift_states\n" in shown
    assert "  read     */**/adapter_door_requests/" in shown  # beyond wheelnav/**
    assert main(["security", "add", str(root), "rmf", "--role", "viewer"]) == 2
    assert "'rmf' is a service's or a reserved name" in capsys.readouterr().out
