"""``gcs-bench daemon``: the daemon's report-to-command latency, its commands' age, the report rate it keeps up with.

Two processes on 127.0.0.1, joined by a Zenoh TCP link (peers, multicast off,
a free port; no MAVLink): the **load** (:mod:`benchmarks.daemon_load`, a spawned
process, ``load_niceness`` below this one's priority: the vehicles' own computers
in use) plays N vehicles; the **daemon** (:class:`gcs.daemon.app.Daemon`, in this
process, running its own loop :meth:`~gcs.daemon.app.Daemon.run`) consumes their
reports. The daemon's ``on_step`` hook notes the wall time at which each
decision step was fused (its ``TrackEstimate`` put); its ``on_plan`` hook, the
time each plan's ``PlanCommand`` messages were put and the planner thread's
share of it (waiting for the previous plan, visibility regions, solve).
Sender and daemon read the same clock (``time.time_ns``, one machine).

For each vehicle count:

1. **Rate search** with the cheap ``orbit`` planner: trials of ``seconds`` at
   1,250, 2,500, 5,000 ... reports/s (evenly spaced), doubling until a trial
   fails, then bisecting to within 15% (or, with ``rates``, one trial at each rate
   given, in turn). A trial **passes** ("processed with
   nothing dropped") when the load achieved the rate, every published report
   was accepted by ingest (``accepted.report``) with no rejection, no late
   report and no failed decision, and the daemon had accepted the last report
   within :data:`GRACE_S` of its send. With reliable Zenoh and an unbounded
   inbox nothing is ever *dropped*: a daemon too slow for the rate falls
   behind instead, and its latency grows without bound; the grace detects that.
2. **Latency** of a step: from the send of the step's last report (the one
   that completed it) to its commands put, less the planner thread's share
   (:func:`step_latencies_ms`). The planner plans the newest fused step only,
   so a step fused while it was busy is served by the next plan for a newer step. Quoted from the trial at the goal rate (5,000
   reports/s) when it passed, else from the fastest passing trial; also with
   the planner's share kept in, and report to ``TrackEstimate``.
3. **Command age** (``command_age_ms_median``, ``command_age_ms_p99``): the vehicle (data) time at which
   each steering command is flown less the stamp of the decision step its plan came from
   (:class:`gcs.engine.memory.CommandAges`; no MAVLink here: the age of the plan each vehicle would be
   steered along, :data:`~gcs.engine.memory.STEER_RATE_HZ` times a second of data time), per trial;
4. **Solve time** of the GA (the scenario's planner, ``ga_k5`` by default) from
   a second daemon fed in real time (one burst of N reports per decision step
   of wall time, so that the GA gets its real deadline); the latency there is
   the daemon's at its real operating point.
"""

from __future__ import annotations

import cProfile
import multiprocessing
import os
import platform
import time
from collections import Counter
from collections.abc import Callable, Generator, Sequence
from dataclasses import asdict

from gcs.adapters.loopback import LOCALHOST
from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from gcs.engine.records import PlanRecord, StepRecord
from gcs.engine.navigation import runs_skf
from gcs.daemon.plan_runners import START_TIMEOUT_S
from benchmarks.daemon_load import LOAD_NICENESS, Fleet, publisher_main
from benchmarks.daemon_report import fmt, format_report, write_json
from benchmarks.daemon_timing import PlanTiming, StepTiming, Trial, percentiles, step_latencies_ms, track_latencies_ms
from benchmarks.urban import with_vehicles
from gcs.config import Scenario
from gcs.core.world import World
from gcs.daemon.niceness import check_niceness
from gcs.engine.tracker_factory import scenario_planner

__all__ = ["GOAL_REPORTS_PER_S", "GOAL_LATENCY_MS_P99", "GRACE_S", "Trial", "StepTiming", "PlanTiming",
           "step_latencies_ms", "track_latencies_ms",
           "next_rate", "run_benchmark", "format_report", "write_json"]

NS_PER_S = 1_000_000_000
GOAL_REPORTS_PER_S = 5000
GOAL_LATENCY_MS_P99 = 20.0
GRACE_S = 0.1
"""A trial passes only if the daemon accepted the last report within this much wall time of its send."""
START_RATE = GOAL_REPORTS_PER_S / 4
RESOLUTION = 1.15
"""The rate search stops when the slowest failing rate is within 15% of the fastest passing one."""
MAX_TRIALS = 9
LATENCY_PLANNER = "orbit"


class _Run:
    """One daemon fed by the load: its own loop (:meth:`Daemon.run`) drives a generator script.

    A script yields False while the daemon should keep turning and returns its
    result when done; the loop calls it once per pass (the ``until`` hook).
    """

    def __init__(self, scenario: Scenario, world: World, planner: str, endpoint: str, conn,
                 profiler: cProfile.Profile | None = None, navigation: str = "auto") -> None:
        self.conn, self.profiler = conn, profiler
        self.roster = [v.id for v in scenario.vehicles]
        self.log: list[StepTiming] = []
        self.plans: list[PlanTiming] = []
        options = DaemonOptions(zenoh=ZenohSettings(mode="peer", listen=(), connect=(endpoint,)), planner=planner,
                                navigation=navigation)
        self.daemon = Daemon(scenario, world, options, on_step=self._on_step, on_plan=self._on_plan)

    def _on_step(self, record: StepRecord) -> None:
        self.log.append(StepTiming(record.stamp_ns, record.fused_ns))

    def _on_plan(self, record: PlanRecord) -> None:
        self.plans.append(PlanTiming(record.stamp_ns, record.finished_ns, time.time_ns(), record.planning_s,
                                     record.solve_s))

    def run(self, script: Generator[bool, None, object]) -> object:
        result = []

        def until() -> bool:
            try:
                return next(script)
            except StopIteration as done:
                result.append(done.value)
                return True

        if self.profiler is not None:
            self.profiler.enable()
        try:
            self.daemon.run(until=until)
        finally:
            if self.profiler is not None:
                self.profiler.disable()
        if not result:
            raise RuntimeError("the daemon stopped before the benchmark finished")
        return result[0]

    def _call(self, *command) -> Generator[bool, None, dict]:
        """Send a command to the load and keep the daemon turning until it answers."""
        self.conn.send(command)
        while not self.conn.poll():
            yield False
        try:
            reply = self.conn.recv()
        except EOFError:
            raise RuntimeError(f"the load process died during {command[0]!r}") from None
        if "error" in reply:
            raise RuntimeError(f"the load process failed during {command[0]!r}: {reply['error']}")
        return reply

    def _counts(self) -> Counter:
        ingest, steps = self.daemon.ingest.counters, self.daemon.steps.counters
        return Counter({"accepted": ingest["accepted.report"],
                        "rejected": sum(v for k, v in ingest.items() if k.startswith("rejected.")),
                        "late": steps["rejected.late"],
                        "errors": self.daemon.counters["errors.decision"] + self.daemon.counters["errors.planning"]})

    def _wait(self, condition: Callable[[], bool], timeout_s: float, what: str) -> Generator[bool, None, None]:
        deadline = time.monotonic() + timeout_s
        while not condition():
            if time.monotonic() > deadline:
                raise RuntimeError(f"benchmark: timed out waiting for {what}")
            yield False

    def pause(self, seconds: float) -> Generator[bool, None, None]:
        """Keep turning for ``seconds``."""
        until = time.monotonic() + seconds
        yield from self._wait(lambda: time.monotonic() >= until, seconds + 1.0, "a pause")

    def warm_up(self) -> Generator[bool, None, None]:
        """Every vehicle alive and plannable, one step decided, and nothing else in flight."""
        registry = self.daemon.registry
        yield from self._wait(lambda: all(registry.alive(v, 0.0) for v in self.roster), 10.0, "liveliness tokens")
        yield from self._call("warmup")
        # the first plan waits for the planner process to start (a few seconds on a busy machine)
        yield from self._wait(lambda: len(registry.plannable(0.0)) == len(self.roster) and self.plans,
                              START_TIMEOUT_S, "the warm-up step's plan")
        yield from self.pause(0.2)

    def trial(self, rate: float, seconds: float, burst: bool = False, scored: bool = True
              ) -> Generator[bool, None, Trial]:
        """Publish at ``rate`` for ``seconds``, wait until everything is accepted (or stalls), and measure.

        ``passed`` is None unless ``scored``. CPU is in cores (CPU seconds per wall second)
        of this process (every thread: the loop, Zenoh's) and of the load process.
        """
        yield from self._call("prepare", rate, seconds, burst)  # the load encodes the trial's reports
        before, first_step, first_plan = self._counts(), len(self.log), len(self.plans)
        ages = self.daemon.engine.command_ages
        ages.ages_ms.clear()  # the trial's own commands
        started, cpu = time.perf_counter(), time.process_time()
        reply = yield from self._call("run")
        published, last_sent = reply["published"], reply["last_sent_ns"][-1]
        progress, stalled_at = -1, time.monotonic()
        while True:
            counts = self._counts() - before
            if counts["accepted"] + counts["rejected"] >= published:
                lag_s = (time.time_ns() - last_sent) / NS_PER_S
                break
            if counts["accepted"] != progress:
                progress, stalled_at = counts["accepted"], time.monotonic()
            elif time.monotonic() - stalled_at > 1.0:
                lag_s = None
                break
            yield False
        wall = time.perf_counter() - started
        sent = dict(zip(reply["stamps"], reply["last_sent_ns"]))
        # the newest step's planning may still wait in the loop (plan_interval_s) before its plan
        yield from self._wait(lambda: not self.daemon.plan_runner.busy and self.daemon.loop.waiting is None, 10.0,
                              "the last plan")
        yield False  # one more pass applies it
        log = [step for step in self.log[first_step:] if step.stamp_ns >= reply["stamps"][0]]
        planned = [plan for plan in self.plans[first_plan:] if plan.stamp_ns >= reply["stamps"][0]]
        achieved = (published - 1) / reply["elapsed_s"] if published > 1 and reply["elapsed_s"] > 0 else float(rate)
        passed = (counts["accepted"] == published and counts["rejected"] == counts["late"] == counts["errors"] == 0
                  and lag_s is not None and lag_s <= GRACE_S and achieved >= 0.97 * rate)
        return Trial(float(rate), achieved, published, counts["accepted"], counts["rejected"], counts["late"],
                     counts["errors"], lag_s, (time.process_time() - cpu) / wall, reply["cpu_s"] / wall,
                     sum(step.stamp_ns in sent for step in log), len(planned),
                     *percentiles(step_latencies_ms(sent, log, planned)),
                     *percentiles(step_latencies_ms(sent, log, planned, planner=True)),
                     *percentiles(track_latencies_ms(sent, log)),
                     percentiles([(plan.planning_s - plan.solve_s) * 1e3 for plan in planned])[0],
                     *percentiles([plan.solve_s * 1e3 for plan in planned]), passed if scored else None,
                     command_age_ms_median=ages.median_ms(), command_age_ms_p99=ages.p99_ms())


def next_rate(trials: Sequence[Trial], minimum: float) -> float | None:
    """The rate to try next: doubling until a failure, then bisection to :data:`RESOLUTION`; None when done."""
    best = max((t.rate_per_s for t in trials if t.passed), default=None)
    worst = min((t.rate_per_s for t in trials if not t.passed), default=None)
    if len(trials) >= MAX_TRIALS:
        return None
    if worst is None:
        return 2 * best if best is not None else START_RATE
    if best is None:
        return worst / 2 if worst / 2 >= minimum else None
    return (best + worst) / 2 if worst / best > RESOLUTION else None


def _search(run: _Run, seconds: float, minimum: float, say: Callable[[str], None],
            rates: Sequence[float] = ()) -> Generator[bool, None, list]:
    """The rate search, or with ``rates`` a trial at each of them in turn (e.g. the goal rate repeated)."""
    yield from run.warm_up()
    trials: list[Trial] = []
    fixed = iter(rates)
    while (rate := next(fixed, None) if rates else next_rate(trials, minimum)) is not None:
        trial = yield from run.trial(round(rate), seconds)
        trials.append(trial)
        say(f"{len(run.roster)} vehicles, {trial.rate_per_s:,.0f} reports/s: "
            f"{'kept up' if trial.passed else 'FAILED'} (achieved {trial.achieved_per_s:,.0f}/s, "
            f"accepted {trial.accepted}/{trial.published}, lag {fmt(trial.lag_s, 3)} s, "
            f"latency p50/p99 {fmt(trial.latency_ms_p50)}/{fmt(trial.latency_ms_p99)} ms, "
            f"visibility {fmt(trial.visibility_ms_median, 1)} ms, "
            f"CPU cores daemon {trial.daemon_cpu:.2f} load {trial.load_cpu:.2f})")
    return trials


def _realtime(run: _Run, steps: int, step_s: float) -> Generator[bool, None, Trial]:
    yield from run.warm_up()
    yield from run.pause(step_s)  # so that data time advances as fast as wall time from the first step on
    return (yield from run.trial(len(run.roster) / step_s, steps * step_s, burst=True, scored=False))


def _measure(scenario: Scenario, world: World, seconds: float, solve_steps: int, ga_planner: str,
             say: Callable[[str], None], profiler: cProfile.Profile | None, navigation: str = "auto",
             rates: Sequence[float] = (), load_niceness: int = LOAD_NICENESS) -> dict:
    """The rate search (orbit) and the GA's solve time for one scenario, against one load process."""
    context = multiprocessing.get_context("spawn")
    ours, theirs = context.Pipe()
    fleet = Fleet.of(scenario, nav_per_round=runs_skf(navigation, scenario))
    load = context.Process(target=publisher_main, args=(theirs, f"tcp/{LOCALHOST}:0", fleet, load_niceness),
                           daemon=True)
    load.start()
    theirs.close()  # so that a dead load process reads as EOF here
    try:
        if not ours.poll(30.0):
            raise RuntimeError("the load process did not start")
        try:
            ready = ours.recv()
        except EOFError:
            raise RuntimeError("the load process died while starting") from None
        endpoint = ready["endpoint"]  # where the system let it listen
        count = len(scenario.vehicles)
        search = _Run(scenario, world, LATENCY_PLANNER, endpoint, ours, profiler, navigation)
        trials = search.run(_search(search, seconds, count / scenario.time.step_s, say, rates))
        ga = None
        if solve_steps > 0:
            realtime = _Run(scenario, world, ga_planner, endpoint, ours, navigation=navigation)
            ga = realtime.run(_realtime(realtime, solve_steps, scenario.time.step_s))
            say(f"{count} vehicles, {ga_planner} in real time: solve median {fmt(ga.solve_ms_median, 1)} ms, "
                f"p99 {fmt(ga.solve_ms_p99, 1)} ms over {ga.planned_steps} steps; latency p50/p99 "
                f"{fmt(ga.latency_ms_p50)}/{fmt(ga.latency_ms_p99)} ms")
        ours.send(("stop",))
        load.join(10.0)
    finally:
        if load.is_alive():
            load.terminate()
            load.join(5.0)
    return _summary(trials, ga) | {"load_nice": ready.get("nice")}


def _summary(trials: list[Trial], ga: Trial | None) -> dict:
    passed = [t for t in trials if t.passed]
    best = max(passed, key=lambda t: t.rate_per_s, default=None)
    quoted = next((t for t in passed if t.rate_per_s == GOAL_REPORTS_PER_S), best)
    return {
        "max_reports_per_s_no_loss": best.rate_per_s if best else 0.0,
        # The planner's share is the whole planning call on the planner thread: its problem (the visibility
        # regions of the predicted points, eq. 22) and the search, and the wait for the previous plan. The
        # required keys exclude it; the latency with it, and the report-to-track latency, are kept beside them.
        "latency_ms_p50": quoted.latency_ms_p50 if quoted else None,
        "latency_ms_p99": quoted.latency_ms_p99 if quoted else None,
        "latency_at_reports_per_s": quoted.rate_per_s if quoted else None,
        "latency_with_planner_ms_p50": quoted.latency_with_planner_ms_p50 if quoted else None,
        "latency_with_planner_ms_p99": quoted.latency_with_planner_ms_p99 if quoted else None,
        "track_latency_ms_p50": quoted.track_latency_ms_p50 if quoted else None,
        "track_latency_ms_p99": quoted.track_latency_ms_p99 if quoted else None,
        "visibility_ms_median": quoted.visibility_ms_median if quoted else None,
        "latency_ms_p99_at_max": best.latency_ms_p99 if best else None,
        "command_age_ms_median": quoted.command_age_ms_median if quoted else None,
        "command_age_ms_p99": quoted.command_age_ms_p99 if quoted else None,
        "realtime_command_age_ms_median": ga.command_age_ms_median if ga else None,
        "realtime_command_age_ms_p99": ga.command_age_ms_p99 if ga else None,
        "solve_ms_median": ga.solve_ms_median if ga else None,
        "solve_ms_p99": ga.solve_ms_p99 if ga else None,
        "solve_steps": ga.planned_steps if ga else 0,
        "realtime_latency_ms_p50": ga.latency_ms_p50 if ga else None,
        "realtime_latency_ms_p99": ga.latency_ms_p99 if ga else None,
        "trials": [asdict(t) for t in trials],
        "realtime_trial": asdict(ga) if ga else None,
    }


def machine_note() -> str:
    """CPU count and model, Python and the system."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            model = next((line.split(":", 1)[1].strip() for line in info if line.startswith("model name")), model)
    except OSError:
        pass
    return f"{os.cpu_count()} CPUs ({model}), Python {platform.python_version()}, {platform.system()} {platform.release()}"


def _load_average() -> str:
    """The 1, 5 and 15 minute load averages: the machine is shared, so say how busy it was."""
    return "/".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "?"


def run_benchmark(scenario: Scenario, world: World, vehicle_counts: Sequence[int] = (10, 50, 100),
                  seconds: float = 3.0, solve_steps: int = 5, command: str = "",
                  progress: Callable[[str], None] | None = None, profiler: cProfile.Profile | None = None,
                  navigation: str = "auto", rates: Sequence[float] = (),
                  load_niceness: int = LOAD_NICENESS) -> dict:
    """Measure every vehicle count; returns the report (see :func:`write_json`).

    ``profiler`` (optional) profiles the daemon's loop during the rate searches. ``rates``
    (optional) replaces the search by one trial at each rate given, in that order.
    ``load_niceness``: how much lower the load process's priority is (0-19).
    """
    check_niceness(load_niceness, "the load's")
    say = progress or (lambda _msg: None)
    planner = scenario_planner(scenario)
    ga_planner = planner if planner.startswith("ga_") else "ga_k5"
    note, load_start = machine_note(), _load_average()
    started = time.monotonic()
    per_count = {str(count): _measure(with_vehicles(scenario, count), world, seconds, solve_steps, ga_planner, say,
                                      profiler, navigation, rates, load_niceness) for count in vehicle_counts}
    largest = str(max(vehicle_counts))
    best_rates = [row["max_reports_per_s_no_loss"] for row in per_count.values()]
    at_goal = [row["latency_at_reports_per_s"] == GOAL_REPORTS_PER_S for row in per_count.values()]
    p99s = [row["latency_ms_p99"] for row in per_count.values()]
    return {
        "scenario": scenario.name, "command": command, "machine": note,
        "load_average": {"start": load_start, "end": _load_average()},
        "latency_planner": LATENCY_PLANNER, "solve_planner": ga_planner, "navigation": navigation,
        "nav_per_round": runs_skf(navigation, scenario), "load_niceness": load_niceness,
        "seconds_per_trial": seconds, "rates": list(rates) or "searched", "grace_s": GRACE_S,
        "wall_s": time.monotonic() - started,
        "vehicles": per_count,
        "max_reports_per_s_no_loss": min(best_rates),
        "latency_ms_p50": per_count[largest]["latency_ms_p50"],
        "latency_ms_p99": per_count[largest]["latency_ms_p99"],
        "latency_vehicles": int(largest),
        "goals": {"reports_per_s": GOAL_REPORTS_PER_S, "latency_ms_p99": GOAL_LATENCY_MS_P99,
                  "rate_met": min(best_rates) >= GOAL_REPORTS_PER_S,
                  "latency_met": all(at_goal) and all(p is not None and p <= GOAL_LATENCY_MS_P99 for p in p99s)},
    }
