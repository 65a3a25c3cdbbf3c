"""The Docker deployment (docker/compose.yaml, docker/Dockerfile, docs/operations.md's Docker section), no engine needed.

Every command a container runs, every health check that runs one of our programs and
every ``gcs``/``sim-vehicles`` command the docs/operations.md's Docker section shows is parsed by the
project's own argparse parsers, so an option renamed in the CLI fails here instead of in
a field deployment. Compose's variable substitution is applied with the defaults the
file gives (and with the overrides docs/operations.md shows).
"""

from __future__ import annotations

import contextlib
import io
import re
import shlex
import tomllib
from importlib.metadata import version
from pathlib import Path

import pytest
import yaml
from packaging.requirements import Requirement

from gcs.adapters.zenoh_session import settings_from_arguments
from gcs.cli import build_parser as gcs_parser
from gcs.scenarios import list_scenarios
from sim_vehicles.cli import build_parser as sim_parser

ROOT = Path(__file__).resolve().parents[2]
DOCKER = ROOT / "docker"
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
PROGRAMS = {"gcs": gcs_parser, "sim-vehicles": sim_parser}
OUR_SERVICES = ("gcs", "sim-vehicles", "recorder")
ROUTER = "tcp/zenoh:7447"

_SUBSTITUTION = re.compile(r"\$(?:(\$)|\{([A-Za-z_]\w*)(?:(:?-)([^}]*))?\}|([A-Za-z_]\w*))")


def interpolate(text: str, env: dict[str, str]) -> str:
    """Compose's substitution: ``$$`` -> ``$``, ``${VAR:-default}``, ``${VAR-default}``, ``${VAR}``, ``$VAR``."""
    assert "$" not in _SUBSTITUTION.sub("", text), f"a '$' compose cannot substitute in {text!r} (write $$)"

    def value(match: re.Match) -> str:
        if match.group(1):
            return "$"
        name, operator, default = match.group(2) or match.group(5), match.group(3), match.group(4)
        if operator == ":-" and not env.get(name):
            return default
        if operator == "-" and name not in env:
            return default
        assert name in env, f"${{{name}}} in {text!r} has no default"
        return env[name]

    return _SUBSTITUTION.sub(value, text)


def parse(argv: list[str], where: str):
    """The namespace our parser gives ``argv``; a test failure naming ``where`` when it does not parse."""
    program = argv[0].rsplit("/", 1)[-1]
    assert program in PROGRAMS, f"{where}: {argv[0]!r} is not one of this project's programs {sorted(PROGRAMS)}"
    stderr = io.StringIO()
    try:
        with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
            return PROGRAMS[program]().parse_args(argv[1:])
    except SystemExit:
        pass  # argparse's message is in stderr; fail outside the handler for a clean report
    pytest.fail(f"{where}: `{shlex.join(argv)}` does not parse: {stderr.getvalue().strip()}")


def compose() -> dict:
    return yaml.safe_load((DOCKER / "compose.yaml").read_text())


def container_argv(service: dict, env: dict[str, str] | None = None) -> list[str]:
    """What the container runs: the command, substituted, with a ``sh -c 'exec ...'`` wrapper removed."""
    command = service["command"]
    words = shlex.split(command) if isinstance(command, str) else command
    assert all(isinstance(w, str) for w in words), f"compose wants every command item a string: {words}"
    argv = [interpolate(w, env or {}) for w in words]
    if argv[:2] == ["sh", "-c"]:
        script = shlex.split(argv[2])
        assert script[0] == "exec", "a shell wrapper must exec the program, or the stop signal stops the shell"
        argv = script[1:]
    return argv


def option(argv: list[str], name: str) -> str:
    return argv[argv.index(name) + 1]


def published(service: dict) -> list[tuple[str, int, int, str]]:
    """(host address, host port, container port, protocol) of each short-syntax port."""
    ports = []
    for text in service.get("ports", []):
        mapping, _, protocol = text.partition("/")
        host_ip, host_port, container_port = mapping.rsplit(":", 2) if mapping.count(":") >= 2 else ("", *mapping.split(":"))
        ports.append((host_ip, int(host_port), int(container_port), protocol or "tcp"))
    return ports


def test_services_images_and_the_zenoh_pin():
    spec = compose()
    services = spec["services"]
    assert set(services) == {"zenoh", *OUR_SERVICES}
    installed = version("eclipse-zenoh")
    pinned = next(Requirement(r) for r in PYPROJECT["project"]["dependencies"] if r.startswith("eclipse-zenoh"))
    assert installed in pinned.specifier, f"eclipse-zenoh {installed} outside pyproject's {pinned}"
    assert services["zenoh"]["image"] == f"eclipse/zenoh:{installed}", "the router must run the Python package's version"
    ours = f"uav-tracking-gcs:{PYPROJECT['project']['version']}"
    for name in OUR_SERVICES:
        service = services[name]
        assert service["image"] == ours
        assert (DOCKER / service["build"]["context"]).resolve() == ROOT
        assert (ROOT / service["build"]["dockerfile"]) == DOCKER / "Dockerfile"
        assert service["init"] is True and service["restart"] == "unless-stopped"


@pytest.mark.parametrize("name", OUR_SERVICES)
def test_every_container_command_parses_as_a_zenoh_client_of_the_router(name):
    args = parse(container_argv(compose()["services"][name]), f"services.{name}.command")
    settings = settings_from_arguments(args)
    assert settings is not None and settings.mode == "client" and list(settings.connect) == [ROUTER]
    assert args.prefix == "gcs"


def test_the_router_listens_where_the_clients_connect_and_serves_rest():
    zenoh = compose()["services"]["zenoh"]
    argv = zenoh["command"]
    assert option(argv, "--listen") == "tcp/0.0.0.0:" + ROUTER.rsplit(":", 1)[1]
    assert option(argv, "--rest-http-port") == "8000" and "--no-multicast-scouting" in argv
    assert {(7447, 7447, "tcp"), (8000, 8000, "tcp")} <= {p[1:] for p in published(zenoh)}


def test_every_published_port_binds_loopback():
    for name, service in compose()["services"].items():
        for host_ip, *_ in published(service):
            assert host_ip == "127.0.0.1", f"services.{name}.ports: bind 127.0.0.1 (docs/operations.md says how to open a LAN)"


def test_health_checks_and_start_order():
    services = compose()["services"]
    router_check = services["zenoh"]["healthcheck"]["test"]
    # eclipse/zenoh is Alpine: BusyBox wget exists, curl does not.
    assert router_check[:2] == ["CMD", "wget"] and "http://127.0.0.1:8000/" in router_check[-1]
    daemon_check = services["gcs"]["healthcheck"]["test"]
    assert daemon_check[0] == "CMD"
    args = parse(daemon_check[1:], "services.gcs.healthcheck")
    assert args.command == "status" and list(settings_from_arguments(args).connect) == [ROUTER]
    for name in ("zenoh", "gcs"):
        assert {"interval", "timeout", "retries", "start_period"} <= set(services[name]["healthcheck"])
    assert services["gcs"]["depends_on"] == {"zenoh": {"condition": "service_healthy"}}
    assert services["sim-vehicles"]["depends_on"] == {"gcs": {"condition": "service_healthy"}}
    assert services["recorder"]["depends_on"] == {"zenoh": {"condition": "service_healthy"}}


def test_mavlink_wiring_and_scenario():
    services = compose()["services"]
    daemon = parse(container_argv(services["gcs"]), "services.gcs.command")
    vehicles = parse(container_argv(services["sim-vehicles"]), "services.sim-vehicles.command")
    assert daemon.command == "run" and vehicles.command == "run"
    assert daemon.scenario == vehicles.scenario and daemon.scenario in list_scenarios()
    # The vehicles serve MAVLink (udpin on every interface of their container, published on
    # the host for MAVProxy or QGroundControl); the daemon is a client of that server.
    kind, host, port = daemon.mavlink.split(":")
    assert (kind, host) == ("udpout", "sim-vehicles")
    assert vehicles.mavlink == f"udpin:0.0.0.0:{port}"
    assert ("127.0.0.1", int(port), int(port), "udp") in published(services["sim-vehicles"])


def test_the_recorder_finishes_its_file_in_the_volume():
    spec = compose()
    recorder = spec["services"]["recorder"]
    assert recorder["stop_signal"] == "SIGINT", "gcs record finishes the MCAP file on SIGINT"
    args = parse(container_argv(recorder), "services.recorder.command")
    assert args.command == "record" and args.duration is None
    volume, target = recorder["volumes"][0].split(":")[:2]
    assert volume in spec["volumes"] and str(args.output.parent) == target
    assert "$(date" in str(args.output), "one file per start, so a restart does not overwrite a recording"


def test_dockerfile_slim_non_root_installs_the_repository():
    lines = [line.strip() for line in (DOCKER / "Dockerfile").read_text().splitlines()]
    instructions = [line for line in lines if line and not line.startswith("#")]
    assert re.fullmatch(r"FROM python:3\.11-slim(-\w+)?", next(i for i in instructions if i.startswith("FROM ")))
    users = [i.split()[1] for i in instructions if i.startswith("USER ")]
    assert users and users[-1] not in ("root", "0"), "the containers must not run as root"
    copied = {source.rstrip("/") for i in instructions if i.startswith("COPY ") for source in i.split()[1:-1]}
    packages = [p.rstrip("*") for p in PYPROJECT["tool"]["setuptools"]["packages"]["find"]["include"]]
    license_files = PYPROJECT["project"].get("license-files", [])
    missing = {"pyproject.toml", "README.md", *license_files, *packages} - copied
    assert not missing, f"the image is built from the repository: COPY {sorted(missing)}"
    install = next(i for i in instructions if "pip install" in i)
    assert "--no-cache-dir" in install and re.search(r"pip install\s+(--\S+\s+)*\.(\s|$)", install)
    assert "[" not in install, "no extras (tests) in the image"
    scripts = set(PYPROJECT["project"]["scripts"])
    assert set(PROGRAMS) <= scripts  # the image holds the ground station's programs (and gcs-bench, unused there)
    assert {container_argv(compose()["services"][n])[0] for n in OUR_SERVICES} <= scripts


def test_dockerignore_keeps_the_context_small():
    patterns = set((ROOT / ".dockerignore").read_text().split())
    assert {".git", ".venv", "**/*.mcap", "**/__pycache__"} <= patterns


def documented_docker_commands() -> list[tuple[str, dict[str, str], list[str] | None]]:
    """(line, VAR=value prefixes, argv of our program or None) for each command line of the docs/operations.md's Docker section."""
    section = (ROOT / "docs" / "operations.md").read_text().split("\n## Docker\n", 1)[1].split("\n## ", 1)[0]
    found = []
    for block in re.findall(r"```(?:sh|bash|console)?\n(.*?)```", section, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            env = {}
            while words and re.fullmatch(r"[A-Za-z_]\w*=.*", words[0]):
                name, _, value = words.pop(0).partition("=")
                env[name] = value
            found.append((line, env, program_argv(words)))
    return found


def program_argv(words: list[str]) -> list[str] | None:
    """Our program's argv in a shell line: run directly, or through ``docker compose run|exec SERVICE``."""
    if words and words[0].rsplit("/", 1)[-1] in PROGRAMS:
        return words
    if words[:2] != ["docker", "compose"] or len(words) < 4 or words[2] not in ("run", "exec"):
        return None
    i = 3
    while words[i].startswith("-"):
        i += 2 if words[i] in ("-e", "--env", "-u", "--user", "-w", "--workdir", "-v", "--volume", "-p",
                               "--publish", "--entrypoint", "--name") else 1
    rest = words[i + 1:]
    return rest if rest and rest[0] in PROGRAMS else None


def test_documented_docker_commands_parse():
    commands = documented_docker_commands()
    ours = [(line, argv) for line, _, argv in commands if argv is not None]
    assert len(ours) >= 2, "the docs/operations.md's Docker section shows gcs commands"
    for line, argv in ours:
        parse(argv, f"docs/operations.md Docker section, `{line.strip()}`")


def test_documented_overrides_give_commands_that_parse_and_are_reachable():
    overrides = [env for _, env, _ in documented_docker_commands() if env]
    assert any("GCS_MAVLINK" in env for env in overrides) and any("GCS_SCENARIO" in env for env in overrides)
    services = compose()["services"]
    for env in overrides:
        daemon = parse(container_argv(services["gcs"], env), f"services.gcs.command with {env}")
        parse(container_argv(services["sim-vehicles"], env), f"services.sim-vehicles.command with {env}")
        assert daemon.scenario in list_scenarios()
        kind, host, port = daemon.mavlink.split(":")
        if kind == "udpin":  # an external autopilot or router on the host must reach the daemon
            assert host == "0.0.0.0" and ("127.0.0.1", int(port), int(port), "udp") in published(services["gcs"])


def test_the_checks_can_fail():
    with pytest.raises(pytest.fail.Exception, match="--no-such-option"):
        parse(["gcs", "run", "--no-such-option"], "here")
    with pytest.raises(pytest.fail.Exception, match="invalid choice"):
        parse(["sim-vehicles", "fly"], "here")
    with pytest.raises(AssertionError, match="not one of this project's programs"):
        parse(["zenohd", "--help"], "here")
    with pytest.raises(AssertionError, match="no default"):
        interpolate("${GCS_UNSET}", {})
    with pytest.raises(AssertionError, match="write"):
        interpolate("$(date)", {})
    assert interpolate("a$${B:-c}${B:-d}${E-f}", {"E": ""}) == "a${B:-c}d"
    assert program_argv(shlex.split("docker compose exec -T gcs gcs status")) == ["gcs", "status"]
    assert program_argv(shlex.split("docker compose logs -f gcs")) is None
