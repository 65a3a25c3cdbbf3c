"""A federation member's live map in headless Chromium: every member's area and every global target.

The live map is served in-process and given the picture of a federation member (``west``) after a member
(``east``) has left: the page must outline the areas of the members present, labelled with their ids, and draw
each global target where the snapshot puts it, labelled with its id and holders, the lost ones dashed and faded,
the ones ``west`` plans for bold.
"""

from __future__ import annotations

import json

import pytest

from gcs.adapters.live_map.outputs import LiveMap
from gcs.config.world import build_world
from tests.e2e.browser import ARTIFACTS, Browser, chromium_binary
from tests.unit.test_live_federation import SCENARIO, first_step, second_step

FEDERATION_STATE = """JSON.stringify((() => {
  const box = (e) => { const r = e.getBoundingClientRect(); return {x: r.x, y: r.y, w: r.width, h: r.height}; };
  const label = (key) => document.querySelector(`#layer-labels .label[data-for="${key}"]`)?.textContent ?? null;
  return {
    areas: [...document.querySelectorAll('#layer-federation-areas .fed-area')].map((r) => ({
      member: r.dataset.member, own: r.dataset.own, box: box(r),
      stroke: parseFloat(getComputedStyle(r).strokeWidth),
      label: document.querySelector(`#layer-federation-areas [data-for="area-${r.dataset.member}"]`)?.textContent})),
    targets: [...document.querySelectorAll('#layer-federation .fed-target')].map((g) => ({
      id: g.dataset.globalId, x: Number(g.dataset.x), y: Number(g.dataset.y), holders: g.dataset.holders,
      lost: g.dataset.lost, claim: g.dataset.claim, opacity: Number(getComputedStyle(g).opacity),
      dashed: getComputedStyle(g.querySelector('.fed-ellipse')).strokeDasharray !== 'none',
      stroke: parseFloat(getComputedStyle(g.querySelector('.fed-ellipse')).strokeWidth),
      mark: box(g.querySelector('.fed-mark')), label: label(`fed-${g.dataset.globalId}`)})),
    legend: [...document.querySelectorAll('.legend-federation')].map((li) => li.hidden),
  };
})())"""


def test_the_page_draws_the_members_areas_and_the_federations_targets(tmp_path) -> None:
    federation, _ = first_step()
    published = second_step(federation)
    live = LiveMap.open(("127.0.0.1", 0), SCENARIO, build_world(SCENARIO))
    try:
        live.observe_federation(published, federation.members)
        assert live.publish(0.0, force=True)
        expected = live.picture.snapshot()[0]["federation"]
        assert live.url is not None
        with Browser(chromium_binary()) as browser:
            browser.open(live.url)
            browser.wait_for("document.querySelectorAll('#layer-federation .fed-target').length === 4", 30.0,
                             "the federation's four targets")
            browser.evaluate("document.getElementById('city').click()")
            browser.wait_for("document.body.dataset.view === 'city' && "
                             "document.getElementById('map').dataset.moving !== 'true'", 30.0, "the whole city")
            state = json.loads(browser.evaluate(FEDERATION_STATE))
            browser.screenshot(ARTIFACTS / "live_map_federation.png")
    finally:
        live.close()

    assert state["legend"] == [False, False]
    areas = {a["member"]: a for a in state["areas"]}
    assert sorted(areas) == ["north", "west"]  # east has left
    assert areas["west"]["own"] == "true" and areas["north"]["own"] == "false"
    assert areas["west"]["stroke"] > areas["north"]["stroke"]
    for member in expected["members"]:  # each rectangle has its area's shape on screen, labelled with its id
        x0, y0, x1, y1 = member["area"]
        drawn = areas[member["id"]]
        assert drawn["box"]["w"] / drawn["box"]["h"] == pytest.approx((x1 - x0) / (y1 - y0), rel=0.02)
        assert drawn["label"].startswith(member["id"] + " (3 vehicles")
    assert areas["north"]["box"]["y"] + areas["north"]["box"]["h"] == pytest.approx(areas["west"]["box"]["y"], abs=1.0)

    drawn = {t["id"]: t for t in state["targets"]}
    for target in expected["targets"]:
        t = drawn[target["global_id"]]
        assert (t["x"], t["y"]) == (target["x"], target["y"])
        assert (t["lost"], t["claim"], t["holders"]) == (str(target["lost"]).lower(), target["claim"] or "",
                                                         ",".join(target["holders"]))
        assert t["label"] == f"{target['global_id']} \u00b7 {', '.join(target['holders']) or 'lost'}"
        assert t["dashed"] == target["lost"] and (t["opacity"] < 1.0) == target["lost"]
        assert (t["stroke"] > 2.0) == (target["claim"] is not None)
    west = areas["west"]["box"]  # west-t4-10 (210, 200) is drawn inside west's area, north-t1 (500, 1500) above it
    centre = lambda t: (t["mark"]["x"] + t["mark"]["w"] / 2, t["mark"]["y"] + t["mark"]["h"] / 2)  # noqa: E731
    x, y = centre(drawn["west-t4-10"])
    assert west["x"] < x < west["x"] + west["w"] and west["y"] < y < west["y"] + west["h"]
    assert centre(drawn["north-t1"])[1] < west["y"]
