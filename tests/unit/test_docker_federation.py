"""The Docker example of a federation (docker/compose.federation.yaml), no engine needed.

Every command a container runs and every health check is parsed by the project's own
parsers, and each daemon's federation flags are checked as ``gcs run`` checks them: three
members under one federation prefix, each with its own team prefix and simulated vehicles,
whose areas split the scenario's city in three strips that cover it without overlap.
"""

from __future__ import annotations

import yaml

from gcs.adapters.engine_cli import federation_options
from gcs.adapters.zenoh_session import settings_from_arguments
from gcs.scenarios import load_scenario
from tests.unit.test_docker_compose import DOCKER, ROUTER, compose, container_argv, option, parse, published

MEMBERS = ("west", "centre", "east")


def federation() -> dict:
    return yaml.safe_load((DOCKER / "compose.federation.yaml").read_text())


def test_the_router_and_the_images_are_the_single_deployments():
    services, single = federation()["services"], compose()["services"]
    assert set(services) == {"zenoh", "recorder", *(f"gcs-{m}" for m in MEMBERS), *(f"sim-{m}" for m in MEMBERS)}
    assert services["zenoh"]["image"] == single["zenoh"]["image"]
    assert services["zenoh"]["command"] == single["zenoh"]["command"]
    for name, service in services.items():
        assert all(host == "127.0.0.1" for host, *_ in published(service)), f"services.{name}.ports"
        if name != "zenoh":
            assert service["image"] == single["gcs"]["image"] and service["build"] == single["gcs"]["build"]


def test_three_members_split_the_city_in_strips_each_with_its_own_team():
    services = federation()["services"]
    areas = []
    for member in MEMBERS:
        daemon = parse(container_argv(services[f"gcs-{member}"]), f"services.gcs-{member}.command")
        vehicles = parse(container_argv(services[f"sim-{member}"]), f"services.sim-{member}.command")
        for args in (daemon, vehicles):
            assert list(settings_from_arguments(args).connect) == [ROUTER] and args.prefix == member
            assert args.scenario == "multitarget_urban"
        scenario = load_scenario(daemon.scenario)
        options = federation_options(daemon, scenario.multitarget is not None, scenario.name)
        assert options is not None and (options.prefix, options.member_id) == ("city", member)
        areas.append(options.area)
        assert option(container_argv(services[f"gcs-{member}"]), "--mavlink") == f"udpout:sim-{member}:14560"
        assert option(container_argv(services[f"sim-{member}"]), "--mavlink") == "udpin:0.0.0.0:14560"
        check = parse(services[f"gcs-{member}"]["healthcheck"]["test"][1:], f"services.gcs-{member}.healthcheck")
        assert check.command == "status" and check.prefix == member
        assert services[f"sim-{member}"]["depends_on"] == {f"gcs-{member}": {"condition": "service_healthy"}}
    width, height = load_scenario("multitarget_urban").city.size_m
    edges = [0.0] + [area[2] for area in areas]
    assert [area[0] for area in areas] == edges[:-1] and edges[-1] == width  # west to east, edge to edge
    assert all((area[1], area[3]) == (0.0, height) for area in areas)


def test_the_recorder_keeps_the_federation():
    args = parse(container_argv(federation()["services"]["recorder"]), "services.recorder.command")
    assert args.command == "record" and args.federation == "city" and args.prefix in MEMBERS
