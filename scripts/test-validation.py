#!/usr/bin/env python3
"""Tests of scripts/validation.py's bookkeeping: how low-end campaigns' shots merge into the
bisections they re-fire (docs/theory.md V5) and what validation/summary.json then says.
Campaigns are stand-ins built here (no dea-mpi run, no record on disk). Standard library
only: run with /usr/bin/python3 scripts/test-validation.py."""
import contextlib
import copy
import io
import json
import importlib.util
import os
import tempfile
import types
import unittest
from unittest import mock

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("validation", os.path.join(HERE, "validation.py"))
validation = importlib.util.module_from_spec(spec)
spec.loader.exec_module(validation)
whole_spec = importlib.util.spec_from_file_location("whole_shots", os.path.join(HERE, "whole-shots.py"))
whole_shots = importlib.util.module_from_spec(whole_spec)
whole_spec.loader.exec_module(whole_shots)

FIXTURE_CASE = {
    "name": "yarn-t-d-i-inf",
    "target": {"kind": "straight_yarn", "fibres_per_yarn": 4, "length_m": 0.0254},
    "bending": {"model": "locked"},
    "contact": {"law": "elastic", "friction_coefficient": 0.3},
    "failure": {"mode": "deterministic"},
    "projectile": {"shape": "cylinder", "velocity_m_s": 150.0},
    "run": {"end_time_s": 1.5e-4},
}
BISECTION = {"kind": "bisection", "low_m_s": 25.0, "high_m_s": 300.0, "resolution_m_s": 10.0}


def shot(velocity, outcome, residual=0.0, index=0, **drawn):
    """A shot record: outcome `P` perforated, `S` stopped, `U` undecided at the end time."""
    record = {
        "id": f"r000-{index:05}",
        "velocity_m_s": velocity,
        "perforated": outcome == "P",
        "residual_velocity_m_s": residual,
        "stopped_by": {"P": "perforated", "S": "stopped", "U": "end_time_s"}[outcome],
        "steps": 1000,
        "wall_s": 1.0,
        "ranks": 1,
    }
    record.update(drawn)
    return record


def campaign(name, case, design, shots):
    case = copy.deepcopy(case)
    case["name"] = name
    return types.SimpleNamespace(name=name, case=case, spec={"name": name, "design": design}, shots=shots, complete=False)


def low_end(name, case, velocities_and_outcomes, end_time=8e-4, **drawn):
    case = copy.deepcopy(case)
    case["run"] = dict(case["run"], end_time_s=end_time)
    shots = [shot(v, o, r, index=k, **drawn) for k, (v, o, r) in enumerate(velocities_and_outcomes)]
    return campaign(name, case, {"kind": "velocities", "velocities_m_s": [v for v, _, _ in velocities_and_outcomes]}, shots)


def fixture_bisection():
    # the bisection as the 4-fibre fixture fired it: the two slowest shots undecided at 150 us
    return campaign("yarn-t-d-i-inf", FIXTURE_CASE, BISECTION,
                    [shot(162.5, "P", 160.0, 0), shot(93.75, "P", 87.7, 1), shot(59.375, "P", 46.7, 2),
                     shot(42.1875, "U", 22.3, 3), shot(50.78125, "U", 25.7, 4)])


class FixtureLowEnds(unittest.TestCase):
    def test_series_of_names_the_low_end_campaigns_apart(self):
        self.assertEqual(validation.series_of("low-end-yarn-36-d-i0"), "single_yarn_low_end")
        self.assertEqual(validation.series_of("low-end-10mm-4-layers"), "panel_size_low_end")
        self.assertEqual(validation.series_of("yarn-36-d-i0"), "single_yarn")

    def test_without_a_re_fire_the_undecided_low_end_is_not_established(self):
        bisection = fixture_bisection()
        entry = validation.entry(bisection, [bisection])
        self.assertEqual((entry["v50_low_m_s"], entry["v50_high_m_s"]), (50.78125, 59.375))
        self.assertIn("not established", entry["method"])
        self.assertIs(entry["v50_low_established"], False)

    def test_a_perforating_re_fire_moves_the_bracket_down_and_a_stop_settles_it(self):
        bisection = fixture_bisection()
        again = low_end("low-end-yarn-t-d-i-inf", FIXTURE_CASE, [(50.78125, "P", 17.5), (42.1875, "S", 0.0)])
        entry = validation.entry(bisection, [bisection, again])
        self.assertEqual((entry["v50_low_m_s"], entry["v50_high_m_s"]), (42.1875, 50.78125))
        self.assertNotIn("not established", entry["method"])
        # settled, though the method's note of the re-fire says "undecided"
        self.assertIs(entry["v50_low_established"], True)
        self.assertIn("the 50.8 m/s shot, undecided at the end time, fired again by low-end-yarn-t-d-i-inf", entry["method"])
        self.assertIn("perforated (17.5 m/s left)", entry["method"])

    def test_a_re_fire_still_undecided_leaves_the_bracket_as_it_was(self):
        bisection = fixture_bisection()
        again = low_end("low-end-yarn-t-d-i-inf", FIXTURE_CASE, [(50.78125, "U", 3.0)])
        entry = validation.entry(bisection, [bisection, again])
        self.assertEqual((entry["v50_low_m_s"], entry["v50_high_m_s"]), (50.78125, 59.375))
        self.assertIn("not established", entry["method"])
        self.assertIs(entry["v50_low_established"], False)

    def test_every_shot_through_gives_no_bracket_but_a_bound(self):
        bisection = campaign("yarn-t-d-i-inf", FIXTURE_CASE, BISECTION,
                             [shot(162.5, "P", 160.0, 0), shot(93.75, "P", 88.1, 1), shot(59.375, "P", 49.6, 2),
                              shot(42.1875, "U", 28.3, 3), shot(50.78125, "P", 39.8, 4)])
        again = low_end("low-end-yarn-t-d-i-inf", FIXTURE_CASE, [(42.1875, "P", 26.0)])
        entry = validation.entry(bisection, [bisection, again])
        self.assertIsNone(entry["v50_m_s"])
        self.assertEqual(entry["v50_below_m_s"], 42.1875)
        # and a slower shot below the bisection's slowest extends it
        lower = low_end("low-end-yarn-t-d-i-inf", FIXTURE_CASE, [(42.1875, "P", 26.0), (33.59375, "S", 0.0)])
        entry = validation.entry(bisection, [bisection, lower])
        self.assertEqual((entry["v50_low_m_s"], entry["v50_high_m_s"]), (33.59375, 42.1875))
        self.assertIn("a 33.6 m/s shot fired by low-end-yarn-t-d-i-inf: stopped", entry["method"])

    def test_every_shot_stopped_gives_a_lower_bound_once_each_is_decided(self):
        bisection = campaign("panel-t-4-layers", FIXTURE_CASE, BISECTION, [shot(250.0, "S", -0.5, 0)])
        entry = validation.entry(bisection, [bisection])
        self.assertIsNone(entry["v50_m_s"])
        self.assertEqual((entry["v50_above_m_s"], entry["v50_below_m_s"]), (250.0, None))
        self.assertEqual(entry["method"], "bisection: no bracket yet (none perforated)")
        # a shot only held at its end time is no stop: no bound
        bisection.shots.append(shot(275.0, "U", 12.0, 1))
        self.assertIsNone(validation.entry(bisection, [bisection])["v50_above_m_s"])
        # a perforation makes a bracket and the bound goes
        bisection.shots[1] = shot(275.0, "P", 40.0, 1)
        entry = validation.entry(bisection, [bisection])
        self.assertEqual((entry["v50_low_m_s"], entry["v50_high_m_s"], entry["v50_above_m_s"]), (250.0, 275.0, None))

    def test_a_decided_shot_is_never_replaced(self):
        bisection = fixture_bisection()
        # 59.4 m/s perforated within 150 us: a re-fire that stopped does not overrule it
        again = low_end("low-end-yarn-t-d-i-inf", FIXTURE_CASE, [(59.375, "S", 0.0)])
        entry = validation.entry(bisection, [bisection, again])
        self.assertEqual(entry["v50_high_m_s"], 59.375)
        self.assertNotIn("low-end-yarn-t-d-i-inf", entry["method"])

    def test_a_low_end_campaign_of_another_case_is_not_merged(self):
        bisection = fixture_bisection()
        other = copy.deepcopy(FIXTURE_CASE)
        other["target"]["fibres_per_yarn"] = 16
        again = low_end("low-end-yarn-t-d-i-inf-16", other, [(50.78125, "P", 17.5)])
        entry = validation.entry(bisection, [bisection, again])
        self.assertEqual((entry["v50_low_m_s"], entry["v50_high_m_s"]), (50.78125, 59.375))

    def test_a_re_fire_that_drew_its_aim_is_named_a_different_shot(self):
        bisection = fixture_bisection()
        again = low_end("low-end-yarn-t-d-i-inf", FIXTURE_CASE, [(50.78125, "P", 17.5)],
                        aim_offset_m=[2.9e-4, -1.1e-4], yaw_deg=1.37, obliquity_deg=0.0)
        entry = validation.entry(bisection, [bisection, again])
        self.assertIn("a different shot: it drew its aim +0.29, -0.11 mm off and +1.37 deg of yaw", entry["method"])

    def test_the_low_end_entries_carry_no_table_6_1_reference(self):
        again = low_end("low-end-yarn-t-d-i-inf", FIXTURE_CASE, [(50.78125, "P", 17.5)])
        entry = validation.entry(again, [again])
        self.assertEqual(entry["series"], "single_yarn_low_end")
        self.assertIsNone(entry["seed_dea_m_s"])
        self.assertIsNone(entry["experiment_m_s"])


class Choices(unittest.TestCase):
    def test_an_entry_names_the_failure_measures_and_rest_angle_law_as_the_solver_reads_them(self):
        panel = {"name": "p", "target": {"kind": "woven_panel", "side_m": 0.01, "layers": 4}, "contact": {},
                 "failure": {}, "projectile": {"preset": "fsp_17_grain"}, "run": {"end_time_s": 1e-4}}
        design = {"kind": "velocities", "velocities_m_s": [200.0]}
        entry = validation.entry(campaign("p", panel, design, [shot(200.0, "S")]))
        # unsaid: the defaults since 2026-12-03, the gauge measure and, on crimped springs, smooth
        self.assertEqual((entry["tension_measure"], entry["shear_measure"], entry["rest_angle_law"]),
                         ("gauge", "gauge", "smooth"))
        named = copy.deepcopy(panel)
        named["failure"]["tension_measure"] = "element"
        named["failure"]["shear_measure"] = "element"
        named["target"]["rest_angle_law"] = "cone"
        entry = validation.entry(campaign("p", named, design, [shot(200.0, "S")]))
        self.assertEqual((entry["tension_measure"], entry["shear_measure"], entry["rest_angle_law"]),
                         ("element", "element", "cone"))
        # springs resting straight: the laws coincide and the solver reports the cone
        straight = copy.deepcopy(panel)
        straight["target"]["weave"] = {"bending_at_rest": "straight"}
        entry = validation.entry(campaign("p", straight, design, [shot(200.0, "S")]))
        self.assertEqual(entry["rest_angle_law"], "cone")
        entry = validation.entry(campaign("y", FIXTURE_CASE, design, [shot(200.0, "S")]))
        self.assertEqual(entry["rest_angle_law"], "cone")


class PanelLowEnds(unittest.TestCase):
    PANEL_CASE = {"name": "panel-t", "target": {"kind": "woven_panel", "side_m": 0.01, "layers": 4},
                  "contact": {}, "projectile": {"preset": "fsp_17_grain", "velocity_m_s": 300.0},
                  "run": {"end_time_s": 1.5e-4}}

    def test_a_panel_low_end_merges_with_the_same_panel_only(self):
        design = {"kind": "bisection", "low_m_s": 100.0, "high_m_s": 500.0, "resolution_m_s": 25.0}
        bisection = campaign("panel-t", self.PANEL_CASE, design,
                             [shot(300.0, "P", 283.8, 0), shot(100.0, "P", 66.2, 1), shot(75.0, "U", 20.0, 2)])
        again = low_end("low-end-t", self.PANEL_CASE, [(75.0, "P", 13.1)], end_time=6e-4)
        entry = validation.entry(bisection, [bisection, again])
        self.assertIsNone(entry["v50_m_s"])
        self.assertEqual(entry["v50_below_m_s"], 75.0)
        thicker = copy.deepcopy(self.PANEL_CASE)
        thicker["target"]["layers"] = 8
        elsewhere = low_end("low-end-t-8", thicker, [(75.0, "P", 13.1)], end_time=6e-4)
        entry = validation.entry(bisection, [bisection, elsewhere])
        self.assertIn("not established", entry["method"])
        # the same size and layers on another mesh (a uniform panel beside a hybrid one) is
        # another target
        uniform = copy.deepcopy(self.PANEL_CASE)
        uniform["target"]["weave"] = {"preset": "km2_style_706", "fibres_per_yarn": 4}
        other_mesh = low_end("low-end-t-uniform", uniform, [(75.0, "P", 13.1)], end_time=6e-4)
        entry = validation.entry(bisection, [bisection, other_mesh])
        self.assertIn("not established", entry["method"])


class Run(unittest.TestCase):
    def test_a_commit_subject_stays_within_72_characters(self):
        short = validation.commit_subject("yarn-4-d-i0", ["145.3 m/s perforated, 2.5 m/s left"])
        self.assertEqual(short, "validation: yarn-4-d-i0 145.3 m/s perforated, 2.5 m/s left")
        name = "mesh-3in-4-fibres-6mm-l0-0.5-rotating-spring-at-break"
        for words in (["400.0 m/s perforated, 338.9 m/s left"], ["400.0 m/s perforated, 338.9 m/s left"] * 3):
            self.assertLessEqual(len(validation.commit_subject(name, words)), 72)
        self.assertEqual(validation.commit_subject("layers-8-3in", ["a"] * 40), "validation: layers-8-3in, 40 shot(s)")

    def test_a_missing_binary_is_named_with_how_to_build_it_not_a_traceback(self):
        with tempfile.TemporaryDirectory() as directory:
            missing = os.path.join(directory, "dea-mpi")
            for given, says in ((missing, "(No such file or directory)"), (None, "build it")):
                args = types.SimpleNamespace(binary=given, ranks=2)
                with mock.patch.object(validation, "ROOT", directory), self.assertRaises(SystemExit) as stop:
                    validation.check(args, "jobs/campaigns/validation/layers-4-3in.json")
                self.assertIn(os.path.join(directory, "") + ("dea-mpi" if given else "target"), str(stop.exception.code))
                self.assertIn(says, str(stop.exception.code))

    def test_a_campaign_file_is_checked_once_until_it_the_binary_or_the_ranks_change(self):
        with tempfile.TemporaryDirectory() as directory, mock.patch.dict(validation.CHECKED, clear=True):
            program, path = os.path.join(directory, "dea-mpi"), os.path.join(directory, "c.json")
            for name, text in ((program, ""), (path, '{"name": "c"}')):
                with open(name, "w") as f:
                    f.write(text)
            calls = []

            def dea_mpi(command, **_):
                calls.append(command)
                return types.SimpleNamespace(returncode=0, stdout=f'{{"checks": {len(calls)}}}', stderr="")

            args = types.SimpleNamespace(binary=program, ranks=2)
            with mock.patch.object(validation.subprocess, "run", dea_mpi):
                first = validation.check(args, path)
                first["checks"] = 99  # a caller's edit does not reach the next answer
                self.assertEqual(validation.check(args, path), {"checks": 1})
                self.assertEqual(len(calls), 1)
                with open(path, "w") as f:
                    f.write('{"name": "c", "design": {}}')
                self.assertEqual(validation.check(args, path), {"checks": 2})
                args.ranks = 1
                self.assertEqual(validation.check(args, path), {"checks": 3})
                built = os.stat(program).st_mtime_ns
                os.utime(program, ns=(built + 10**9, built + 10**9))
                self.assertEqual(validation.check(args, path), {"checks": 4})
                self.assertEqual(validation.check(args, path), {"checks": 4})
            self.assertEqual([c[1:] for c in calls], [["check", path, "--ranks", r] for r in ("2", "2", "1", "1")])

    def test_a_shot_is_not_bound_to_the_cores_another_loop_holds(self):
        c = campaign("layers-t", FIXTURE_CASE, BISECTION, [])
        c.path = "jobs/campaigns/validation/layers-t.json"
        for ranks in (1, 2, 64):
            command = validation.shot_command(types.SimpleNamespace(ranks=ranks, binary="dea-mpi"), c)
            self.assertEqual(command[:5], ["mpirun", "--bind-to", "none", "-np", str(ranks)])
            self.assertEqual("--oversubscribe" in command, ranks > os.cpu_count())
            self.assertEqual(command[command.index("dea-mpi"):][:2], ["dea-mpi", "v50"])

    def test_a_filtered_run_says_its_filter_is_done_not_every_campaign(self):
        done = campaign("yarn-t-d-i0", FIXTURE_CASE, BISECTION, [])
        done.complete = True
        waiting = campaign("layers-t", FIXTURE_CASE, BISECTION, [])
        args = types.SimpleNamespace(only="yarn-t", max_shots=None)
        printed = io.StringIO()
        with mock.patch.object(validation, "load_all", lambda _: [done, waiting]), contextlib.redirect_stdout(printed):
            self.assertEqual(validation.run(args, [done]), 0)
        self.assertIn("whose name contains 'yarn-t' is complete; 1 other(s) still to run", printed.getvalue())
        self.assertNotIn("every validation campaign is complete", printed.getvalue())

    def test_a_signal_to_the_script_reaches_mpirun_as_usr1_and_ends_the_run_with_75(self):
        # A stand-in for mpirun as Open MPI 4 behaves: SIGUSR1 is forwarded to the ranks, which
        # checkpoint and exit 75; SIGTERM kills them and mpirun exits 1.
        import signal
        import sys
        import tempfile
        import threading
        import time
        with tempfile.TemporaryDirectory() as scratch:
            ready, got = os.path.join(scratch, "ready"), os.path.join(scratch, "got")
            stand_in = (
                "import signal, sys, time\n"
                f"def on(signum, _):\n    open({got!r}, 'w').write(signal.Signals(signum).name)\n"
                "    sys.exit(75 if signum == signal.SIGUSR1 else 1)\n"
                "signal.signal(signal.SIGUSR1, on)\nsignal.signal(signal.SIGTERM, on)\n"
                f"open({ready!r}, 'w').close()\n"
                "time.sleep(60)\nsys.exit(0)\n")
            c = campaign("layers-t", FIXTURE_CASE, BISECTION, [])
            c.refresh = lambda: None
            later = campaign("layers-u", FIXTURE_CASE, BISECTION, [])
            fired = []

            def command(_args, campaign_fired):
                fired.append(campaign_fired.name)
                return [sys.executable, "-c", stand_in]

            def signal_when_ready():
                for _ in range(600):
                    if os.path.exists(ready):
                        break
                    time.sleep(0.05)
                os.kill(os.getpid(), signal.SIGTERM)

            args = types.SimpleNamespace(only=None, max_shots=None, commit=False)
            before = signal.getsignal(signal.SIGTERM)
            errors = io.StringIO()
            with mock.patch.object(validation, "shot_command", command), \
                    mock.patch.object(validation, "take_on_held", lambda _: None), \
                    contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(errors):
                threading.Thread(target=signal_when_ready).start()
                code = validation.run(args, [c, later])
            with open(got) as f:
                self.assertEqual(f.read(), "SIGUSR1")
            self.assertEqual(code, 75)
            self.assertEqual(fired, ["layers-t"])
            self.assertIn("signal SIGTERM: the shot checkpoints and the run stops", errors.getvalue())
            self.assertIs(signal.getsignal(signal.SIGTERM), before)

    def test_a_signal_between_shots_fires_no_further_shot(self):
        c = campaign("layers-t", FIXTURE_CASE, BISECTION, [])
        stop = validation.StopForwarder()
        stop.asked = True
        args = types.SimpleNamespace(only=None, max_shots=None, commit=False)
        errors = io.StringIO()
        with mock.patch.object(validation, "take_on_held", lambda _: None), contextlib.redirect_stderr(errors):
            self.assertEqual(validation.run_until_stopped(args, [c], stop), 75)
        self.assertIn("layers-t: stopped by a signal before its next shot", errors.getvalue())

    def run_firing_nothing(self, edit):
        """run_until_stopped with a `dea-mpi v50` that fires no shot, on a campaign whose file
        `edit` changes after it was loaded: the message it ends with."""
        with tempfile.TemporaryDirectory() as scratch:
            c = campaign("layers-t", FIXTURE_CASE, {"kind": "up_and_down", "shots": 12}, [])
            c.path = os.path.join(scratch, "layers-t.json")
            with open(c.path, "w") as f:
                validation.json.dump(edit(copy.deepcopy(c.spec)), f)
            c.refresh = lambda: None
            stop = validation.StopForwarder()
            stop.call = lambda _command: 0
            args = types.SimpleNamespace(only=None, max_shots=None, commit=False)
            with mock.patch.object(validation, "take_on_held", lambda _: None), \
                    mock.patch.object(validation, "shot_command", lambda _a, _c: ["true"]), \
                    contextlib.redirect_stdout(io.StringIO()), self.assertRaises(SystemExit) as ended:
                validation.run_until_stopped(args, [c], stop)
            return str(ended.exception.code)

    def test_a_design_edited_while_the_script_ran_is_named_not_reported_as_no_shot(self):
        def cut(spec):
            spec["design"]["shots"] = 4
            return spec
        message = self.run_firing_nothing(cut)
        self.assertIn("layers-t.json changed while this script ran", message)
        self.assertIn("run again", message)
        self.assertIn("layers-t: dea-mpi v50 fired no shot and the design is not complete",
                      self.run_firing_nothing(lambda spec: spec))


def at(velocity, outcome, index, replicate):
    """A shot record with its place in the campaign, as `dea-mpi v50` writes it."""
    record = shot(velocity, outcome, index=index, replicate=replicate)
    record["id"], record["index"] = f"r{replicate:03}-{index:05}", index
    return record


class HeldShots(unittest.TestCase):
    """A shot undecided at an end time the campaign has since raised goes on from its
    checkpoint, when it is the last of its replicate and its run directory is on the machine."""

    def held(self, shots, states, end_time=2.5e-4):
        case = copy.deepcopy(FIXTURE_CASE)
        case["run"]["end_time_s"] = end_time
        c = campaign("layers-t", case, {"kind": "up_and_down"}, shots)
        return validation.held_to_take_on(c, lambda name, shot_id: states.get(shot_id, (None, False)))

    def test_the_last_shot_held_at_a_shorter_end_time_is_taken_on(self):
        shots = [at(212.5, "S", 0, 0), at(218.75, "U", 1, 0)]
        self.assertEqual(self.held(shots, {"r000-00001": (1.5e-4, True)}), [("r000-00001", 1.5e-4)])

    def test_a_shot_held_at_the_campaign_end_time_is_left(self):
        shots = [at(218.75, "U", 0, 0)]
        self.assertEqual(self.held(shots, {"r000-00000": (2.5e-4, True)}), [])

    def test_a_shot_without_its_run_directory_or_checkpoint_is_left(self):
        shots = [at(218.75, "U", 0, 0)]
        self.assertEqual(self.held(shots, {}), [])
        self.assertEqual(self.held(shots, {"r000-00000": (1.5e-4, False)}), [])

    def test_a_held_shot_with_later_shots_on_record_is_left(self):
        shots = [at(218.75, "U", 0, 0), at(225.0, "P", 1, 0)]
        self.assertEqual(self.held(shots, {"r000-00000": (1.5e-4, True)}), [])
        # another replicate's later shots do not hold it
        shots = [at(218.75, "U", 0, 0), at(225.0, "P", 1, 1)]
        self.assertEqual(self.held(shots, {"r000-00000": (1.5e-4, True)}), [("r000-00000", 1.5e-4)])

    def test_a_run_withdraws_the_record_and_fires_the_shot_again(self):
        import tempfile
        with tempfile.TemporaryDirectory() as results:
            shots_dir = os.path.join(results, "layers-t", "shots")
            os.makedirs(os.path.join(shots_dir, "r000-00000", "checkpoint"))
            held = at(218.75, "U", 0, 0)
            for path, text in ((os.path.join(shots_dir, "r000-00000.json"), validation.json.dumps(held)),
                               (os.path.join(shots_dir, "r000-00000", "summary.json"), '{"simulated_time_s": 1.5e-4}'),
                               (os.path.join(shots_dir, "r000-00000", "checkpoint", "manifest.h5"), "")):
                with open(path, "w") as f:
                    f.write(text)
            case = copy.deepcopy(FIXTURE_CASE)
            case["run"]["end_time_s"] = 2.5e-4
            c = campaign("layers-t", case, {"kind": "up_and_down"}, [held])
            c.refresh = lambda: setattr(c, "shots", validation.records("layers-t"))
            printed = io.StringIO()
            with mock.patch.object(validation, "RESULTS", results), contextlib.redirect_stdout(printed):
                validation.take_on_held(c)
            self.assertEqual(c.shots, [])
            self.assertFalse(os.path.exists(os.path.join(shots_dir, "r000-00000.json")))
            self.assertIn("shot r000-00000 was undecided at its end, 150.0 us, and the campaign now ends at 250.0 us",
                          printed.getvalue())


    def test_a_withdrawn_record_is_not_committed_as_a_finished_shot(self):
        import tempfile
        with tempfile.TemporaryDirectory() as root:
            shots_dir = os.path.join(root, "validation", "layers-t", "shots")
            os.makedirs(shots_dir)
            finished = at(212.5, "S", 0, 0)
            with open(os.path.join(shots_dir, "r000-00000.json"), "w") as f:
                f.write(validation.json.dumps(finished))
            c = campaign("layers-t", FIXTURE_CASE, {"kind": "up_and_down"}, [finished])
            # git lists the new record and the withdrawn one (deleted from the tree)
            listed = "validation/layers-t/shots/r000-00000.json\nvalidation/layers-t/shots/r000-00001.json\n"
            committed = []
            with mock.patch.object(validation, "ROOT", root), \
                    mock.patch.object(validation, "RESULTS", os.path.join(root, "validation")), \
                    mock.patch.object(validation.subprocess, "run", lambda *a, **k: types.SimpleNamespace(stdout=listed)), \
                    mock.patch.object(validation, "write_summary", lambda campaigns: None), \
                    mock.patch.object(validation, "commit", lambda c, new: committed.append(new)):
                validation.commit_pending([c], [c])
            self.assertEqual(committed, [["r000-00000"]])


class Begun(unittest.TestCase):
    """`status` names the shots begun on this machine and not yet on record."""

    def test_a_begun_shot_is_named_with_its_time_and_whether_it_goes_on(self):
        import tempfile
        with tempfile.TemporaryDirectory() as results:
            shots_dir = os.path.join(results, "layers-t", "shots")
            for shot_id, checkpointed in (("r000-00000", False), ("r000-00001", True), ("r000-00002", True)):
                os.makedirs(os.path.join(shots_dir, shot_id, "checkpoint"))
                with open(os.path.join(shots_dir, shot_id, "progress.json"), "w") as f:
                    f.write('{"simulated_time_s": 3.7e-6, "end_time_s": 2.5e-4}')
                if checkpointed:
                    open(os.path.join(shots_dir, shot_id, "checkpoint", "manifest.h5"), "w").close()
            # r000-00000 is on record: finished, not begun
            with open(os.path.join(shots_dir, "r000-00000.json"), "w") as f:
                f.write(validation.json.dumps(at(212.5, "S", 0, 0)))
            # a run directory without progress.json (set-up not done) is not named
            os.makedirs(os.path.join(shots_dir, "r000-00003"))
            with mock.patch.object(validation, "RESULTS", results):
                started = validation.begun("layers-t")
            self.assertEqual([s[0] for s in started], ["r000-00001", "r000-00002"])
            self.assertEqual([s[4] for s in started], [None, None])
            # no state in progress.json: not stepping, however fresh the file
            self.assertEqual([s[5] for s in started], [False, False])
            self.assertEqual(validation.begun_words([("r000-00001", 3.7e-6, 2.5e-4, True, None, False),
                                                     ("r000-00002", 1.2e-5, 2.5e-4, False, None, False)]),
                             "r000-00001 at 3.7 of 250 us, goes on from its checkpoint; "
                             "r000-00002 at 12.0 of 250 us, no checkpoint: starts again")
            # where progress.json names its checkpoint, status says where the shot goes on from
            # (an 8-layer shot said "at 28.4 us, goes on from its checkpoint", which was at 19.8)
            with open(os.path.join(shots_dir, "r000-00001", "progress.json"), "w") as f:
                f.write('{"simulated_time_s": 2.84e-5, "end_time_s": 2.5e-4, "checkpoint_time_s": 1.98e-5}')
            with mock.patch.object(validation, "RESULTS", results):
                started = validation.begun("layers-t")
            self.assertEqual(validation.begun_words(started[:1]),
                             "r000-00001 at 28.4 of 250 us, goes on from its checkpoint at 19.8 us")
            # a shot stepping now (state "running", rewritten moments ago) is said to be so,
            # not to go on from its checkpoint; left alone longer than a few minutes in state
            # "running", it was stopped (a SIGKILL or a lost node writes no other state)
            def said(state, checkpoint_s, *ages_s):
                """What status says of r000-00001 with `state` and `checkpoint_s` in its
                progress.json, that many seconds after the file was written."""
                path = os.path.join(shots_dir, "r000-00001", "progress.json")
                with open(path, "w") as f:
                    json.dump({"simulated_time_s": 2.84e-5, "end_time_s": 2.5e-4,
                               "checkpoint_time_s": checkpoint_s, "state": state}, f)
                written = os.path.getmtime(path)
                with mock.patch.object(validation, "RESULTS", results):
                    return [validation.begun_words(validation.begun("layers-t", now=written + age)[:1])
                            for age in ages_s]
            self.assertEqual(said("running", 1.98e-5, 30.0, validation.RUNNING_WITHIN_S + 1.0),
                             ["r000-00001 at 28.4 of 250 us, stepping now",
                              "r000-00001 at 28.4 of 250 us, goes on from its checkpoint at 19.8 us"])
            # a shot a signal stopped says so at once ("interrupted"), however fresh the file
            self.assertEqual(said("interrupted", 2.84e-5, 1.0),
                             ["r000-00001 at 28.4 of 250 us, goes on from its checkpoint at 28.4 us"])


class UpAndDown(unittest.TestCase):
    UP_AND_DOWN = {"kind": "up_and_down", "start_m_s": 300.0, "step_m_s": 25.0, "shots": 2}
    NO_ZONE = "no zone of mixed results"

    def entry_of(self, shots, mil_std, firth=None):
        c = campaign("layers-t", FIXTURE_CASE, self.UP_AND_DOWN, shots)
        report = {"logistic": {"Err": self.NO_ZONE}, "mil_std_662f": mil_std}
        if firth is not None:
            velocity, low, high = firth
            report["firth_logistic"] = {"Ok": {"v50": {"velocity": velocity, "profile_low": low, "profile_high": high}}}
        with mock.patch.object(validation, "campaign_report", lambda c: report):
            return validation.entry(c, [c])

    def test_two_shots_that_bracket_the_limit_give_the_bracket(self):
        e = self.entry_of([shot(300.0, "S", -0.4, 0), shot(325.0, "P", 94.6, 1)],
                          {"Err": "3 shots of each outcome are needed"})
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (300.0, 312.5, 325.0))
        self.assertIn("no MIL-STD-662F: 3 shots of each outcome are needed", e["method"])
        self.assertIn(self.NO_ZONE, e["method"])

    def test_mil_std_gives_its_mean_within_the_bracket(self):
        shots = [shot(200.0, "S", -0.9, 0), shot(225.0, "P", 61.6, 1)]
        e = self.entry_of(shots, {"Ok": {"v50": 212.5, "count": 3}})
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (200.0, 212.5, 225.0))
        self.assertTrue(e["method"].startswith("MIL-STD-662F mean of the 3"))

    def test_a_mil_std_mean_outside_the_bracket_gives_the_bracket(self):
        shots = [shot(200.0, "S", -0.9, 0), shot(218.75, "S", -0.3, 1), shot(225.0, "P", 61.6, 2)]
        e = self.entry_of(shots, {"Ok": {"v50": 217.7, "count": 3}})
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (218.75, 221.875, 225.0))
        self.assertIn("217.7 m/s, falls outside it", e["method"])

    def ml_entry(self, shots, profile):
        c = campaign("layers-t", FIXTURE_CASE, self.UP_AND_DOWN, shots)
        report = {"logistic": {"Ok": {"v50": {"velocity": 210.0, "low": 206.0, "high": 214.0,
                                              "profile_low": profile[0], "profile_high": profile[1]}}},
                  "mil_std_662f": {"Ok": {"v50": 209.9, "count": 3}},
                  "firth_logistic": {"Ok": {"v50": {"velocity": 210.0, "profile_low": 44.1, "profile_high": 377.9}}}}
        with mock.patch.object(validation, "campaign_report", lambda c: report):
            return validation.entry(c, [c])

    def test_a_logistic_fit_whose_profile_interval_leaves_the_speeds_fired_is_not_quoted(self):
        # the 7-fibre series' seven shots (2026-12-01): a maximum-likelihood fit exists, its
        # delta interval is 206-214 m/s, but its profile interval has no low end
        shots = [shot(206.25, "S", -0.5, 0), shot(206.25, "S", -0.4, 1), shot(209.375, "P", 27.0, 2),
                 shot(212.5, "P", 48.5, 3), shot(212.5, "P", 30.0, 4), shot(212.5, "S", -0.2, 5),
                 shot(218.75, "P", 57.3, 6)]
        e = self.ml_entry(shots, (None, 307.5))
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (206.25, 209.9, 218.75))
        self.assertIn("profile-likelihood interval (no end to 307.5 m/s) reaches beyond the speeds fired "
                      "(206.2–218.8 m/s)", e["method"])
        self.assertTrue(e["method"].startswith("MIL-STD-662F mean of the 3"))
        # the same shots with a profile interval inside the speeds fired quote the delta interval
        e = self.ml_entry(shots, (207.0, 214.0))
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (206.0, 210.0, 214.0))
        self.assertEqual(e["method"], "logistic maximum likelihood, 95 % interval (delta method)")

    def test_outcomes_mixed_at_one_speed_give_the_speeds_around_it(self):
        # both outcomes at 218.75 m/s: the logistic has no maximum (quasi-complete separation),
        # so the range is the nearest speeds at which every shot went one way
        shots = [shot(215.625, "S", -0.4, 0), shot(218.75, "P", 8.5, 1), shot(218.75, "S", -0.6, 2),
                 shot(225.0, "P", 61.6, 3)]
        e = self.entry_of(shots, {"Ok": {"v50": 217.7, "count": 3}})
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (215.625, 217.7, 225.0))
        self.assertIn("around those that mix (218.8 m/s): 215.6–225.0 m/s;", e["method"])
        self.assertIs(e["v50_low_established"], True)
        # nothing above the mixed speed went through every time: the range ends there
        e = self.entry_of(shots[:3], {"Err": "3 shots of each outcome are needed"})
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (215.625, 217.1875, 218.75))
        self.assertTrue(e["method"].startswith("The nearest speeds with one outcome"))
        self.assertIn("215.6–218.8 m/s (none above: the range ends at the mixed speed)", e["method"])
        self.assertNotIn("none below", e["method"])

    def test_firth_within_the_speeds_fired_gives_its_v50_and_interval(self):
        # the 4-layer series' shape: mixed at 218.75 only; Firth's interval lies within the
        # speeds fired, so it is the entry's
        shots = [shot(200.0, "S", -0.9, 0), shot(215.625, "S", -0.4, 1), shot(218.75, "P", 8.5, 2),
                 shot(218.75, "S", -0.6, 3), shot(225.0, "P", 61.6, 4)]
        e = self.entry_of(shots, {"Ok": {"v50": 217.7, "count": 3}}, firth=(217.6, 214.1, 220.6))
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (214.1, 217.6, 220.6))
        self.assertTrue(e["method"].startswith("Firth's penalised logistic, 95 % profile"), e["method"])
        self.assertIn(self.NO_ZONE, e["method"])
        self.assertIs(e["v50_low_established"], True)
        # a partial undecided at its end time counts as one, and the low end is not established
        e = self.entry_of(shots[:4] + [shot(210.0, "U", 3.0, 5), shot(225.0, "P", 61.6, 4)],
                          {"Ok": {"v50": 217.7, "count": 3}}, firth=(217.6, 214.1, 220.6))
        self.assertIs(e["v50_low_established"], False)
        self.assertIn("undecided at the end time", e["method"])

    def test_firth_without_a_mixed_speed_keeps_the_bracket(self):
        # every partial below every complete: any limit between them fits the shots, so an
        # interval within that bracket is the penalty's; the bracket stands
        shots = [shot(200.0, "S", -0.9, 0), shot(200.0, "S", -0.8, 1), shot(225.0, "P", 61.6, 2), shot(250.0, "P", 99.0, 3)]
        e = self.entry_of(shots, {"Err": "3 shots of each outcome are needed"}, firth=(212.1, 201.8, 221.8))
        self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (200.0, 212.5, 225.0))
        self.assertIn("Firth's penalised logistic gives V50 212.1 m/s, but its 95 % interval (201.8 to 221.8 m/s) "
                      "is the penalty's rather than the shots': no speed holds both outcomes", e["method"])

    def test_firth_reaching_beyond_the_speeds_fired_keeps_the_bracket(self):
        # three shots: Firth's interval spans hundreds of m/s (or is unbounded, null in JSON);
        # the bracket stands and the method names Firth's numbers
        shots = [shot(300.0, "S", -0.4, 0), shot(312.5, "P", 40.0, 1), shot(325.0, "P", 94.6, 2)]
        for interval, words in (((-95.8, 717.0), "(-95.8 to 717.0 m/s)"), ((290.0, None), "(290.0 to unbounded m/s)")):
            e = self.entry_of(shots, {"Err": "3 shots of each outcome are needed"}, firth=(307.2, *interval))
            self.assertEqual((e["v50_low_m_s"], e["v50_m_s"], e["v50_high_m_s"]), (300.0, 306.25, 312.5))
            self.assertIn(f"Firth's penalised logistic gives V50 307.2 m/s, but its 95 % interval {words} "
                          "reaches beyond the speeds fired (300.0–325.0 m/s)", e["method"])

    def test_a_low_end_only_undecided_is_not_established(self):
        undecided = [shot(300.0, "U", 22.1, 0), shot(325.0, "P", 94.6, 1)]
        e = self.entry_of(undecided, {"Err": "3 shots of each outcome are needed"})
        self.assertIs(e["v50_low_established"], False)
        self.assertIn("not established", e["method"])
        e = self.entry_of(undecided + [shot(300.0, "S", -0.4, 2)], {"Err": "3 shots of each outcome are needed"})
        self.assertIs(e["v50_low_established"], True)
        self.assertNotIn("not established", e["method"])

    def test_one_outcome_only_gives_no_bracket(self):
        e = self.entry_of([shot(300.0, "S", -0.4, 0)], {"Err": "3 shots of each outcome are needed"})
        self.assertIsNone(e["v50_m_s"])
        self.assertIsNone(e["v50_low_m_s"])
        # but a side: above the fastest stop, each decided; below the slowest perforation
        self.assertEqual((e["v50_above_m_s"], e["v50_below_m_s"]), (300.0, None))
        self.assertIn("every shot stopped: V50 lies above 300.0 m/s", e["method"])
        e = self.entry_of([shot(212.5, "P", 48.5, 0), shot(206.25, "P", 20.0, 1)], {"Err": "3 shots of each outcome are needed"})
        self.assertEqual((e["v50_above_m_s"], e["v50_below_m_s"]), (None, 206.25))
        self.assertIn("every shot perforated: V50 lies below 206.2 m/s", e["method"])
        # a stop only undecided at its end time bounds nothing
        e = self.entry_of([shot(300.0, "U", 12.0, 0)], {"Err": "3 shots of each outcome are needed"})
        self.assertEqual((e["v50_above_m_s"], e["v50_below_m_s"]), (None, None))


class Pools(unittest.TestCase):
    UP_AND_DOWN = {"kind": "up_and_down", "start_m_s": 250.0, "step_m_s": 25.0, "shots": 4}

    def test_a_step_series_pools_with_the_campaign_it_refines_once_it_has_shots(self):
        coarse = campaign("layers-t", FIXTURE_CASE, self.UP_AND_DOWN, [shot(200.0, "S", -0.9, 0), shot(225.0, "P", 60.0, 1)])
        finer = campaign("layers-t-step-6.25", FIXTURE_CASE, self.UP_AND_DOWN, [shot(212.5, "S", -0.3, 0)])
        unfired = campaign("layers-u-step-6.25", FIXTURE_CASE, self.UP_AND_DOWN, [])
        alone = campaign("layers-v-step-6.25", FIXTURE_CASE, self.UP_AND_DOWN, [shot(212.5, "S", -0.3, 0)])
        groups = validation.step_pools([finer, coarse, unfired, alone])
        self.assertEqual([(a.name, [b.name for b in f]) for a, f in groups], [("layers-t", ["layers-t-step-6.25"])])
        # a still finer series joins the same pool, coarsest step first
        finest = campaign("layers-t-step-3.125", FIXTURE_CASE, self.UP_AND_DOWN, [shot(215.625, "P", 5.0, 0)])
        groups = validation.step_pools([finest, finer, coarse])
        self.assertEqual([(a.name, [b.name for b in f]) for a, f in groups],
                         [("layers-t", ["layers-t-step-6.25", "layers-t-step-3.125"])])

    def test_a_pooled_entry_gives_the_fit_of_the_shots_together(self):
        coarse = campaign("layers-t", FIXTURE_CASE, self.UP_AND_DOWN, [shot(200.0, "S", -0.9, 0), shot(225.0, "P", 60.0, 1)])
        finer = campaign("layers-t-step-6.25", FIXTURE_CASE, self.UP_AND_DOWN,
                         [shot(212.5, "S", -0.3, 0), shot(218.75, "P", 20.0, 1), shot(212.5, "P", 10.0, 2)])
        pooled_shots = [dict(s, id=f"{c.name}/{s['id']}") for c in (coarse, finer) for s in c.shots]
        report = {"shots": pooled_shots, "logistic": {"Ok": {"v50": {"velocity": 213.0, "low": 205.0, "high": 221.0,
                                                                              "profile_low": 207.0, "profile_high": 222.0}}}}
        e = validation.pooled_entry(coarse, [finer], [coarse, finer], report)
        self.assertEqual(e["name"], "layers-t + step-6.25")
        self.assertEqual(e["pooled_from"], ["layers-t", "layers-t-step-6.25"])
        self.assertEqual((e["shots"], e["v50_m_s"], e["v50_low_m_s"], e["v50_high_m_s"]), (5, 213.0, 205.0, 221.0))
        self.assertTrue(e["method"].startswith("logistic maximum likelihood"))
        # its core-hours are its campaigns' own: not counted twice
        self.assertIsNone(e["core_hours"])
        text = validation.shots_markdown([coarse, finer], [validation.entry(c, [coarse, finer]) for c in (coarse, finer)] + [e])
        self.assertIn("- `layers-t` and `layers-t-step-6.25`, 5 shots: V50 213.0 m/s (205.0–221.0)", text)


    def test_three_series_pool_into_one_entry_named_by_their_steps(self):
        coarse = campaign("layers-t", FIXTURE_CASE, self.UP_AND_DOWN, [shot(200.0, "S", -0.9, 0), shot(225.0, "P", 60.0, 1)])
        finer = campaign("layers-t-step-6.25", FIXTURE_CASE, self.UP_AND_DOWN, [shot(212.5, "S", -0.3, 0)])
        finest = campaign("layers-t-step-3.125", FIXTURE_CASE, self.UP_AND_DOWN, [shot(215.625, "P", 5.0, 0)])
        pooled_shots = [dict(s, id=f"{c.name}/{s['id']}") for c in (coarse, finer, finest) for s in c.shots]
        report = {"shots": pooled_shots, "logistic": {"Ok": {"v50": {"velocity": 214.0, "low": 207.0, "high": 221.0,
                                                                              "profile_low": 208.0, "profile_high": 222.0}}}}
        every = [coarse, finer, finest]
        e = validation.pooled_entry(coarse, [finer, finest], every, report)
        self.assertEqual(e["name"], "layers-t + step-6.25 + step-3.125")
        self.assertEqual(e["pooled_from"], ["layers-t", "layers-t-step-6.25", "layers-t-step-3.125"])
        self.assertEqual(e["shots"], 4)
        text = validation.shots_markdown(every, [validation.entry(c, every) for c in every] + [e])
        self.assertIn("- `layers-t`, `layers-t-step-6.25` and `layers-t-step-3.125`, 4 shots: V50 214.0 m/s", text)


class ShotTables(unittest.TestCase):
    def test_every_shot_on_record_is_a_row_with_its_draws_and_outcome(self):
        fired = campaign("yarn-t-d-i-inf", FIXTURE_CASE, BISECTION,
                         [shot(162.5, "P", 160.0, 0, aim_offset_m=[3e-4, 4e-4], yaw_deg=-1.25, obliquity_deg=0.0),
                          shot(59.375, "S", -0.4, 1), shot(42.1875, "U", 22.3, 2)])
        waiting = campaign("layers-t", FIXTURE_CASE, {"kind": "up_and_down", "start_m_s": 300.0, "step_m_s": 25.0,
                                                      "shots": 12}, [])
        campaigns = [fired, waiting]
        text = validation.shots_markdown(campaigns, [validation.entry(c, campaigns) for c in campaigns])
        self.assertIn("## yarn-t-d-i-inf", text)
        self.assertIn("bisection from [25, 300] m/s to 10 m/s; 3 on record, in progress.", text)
        self.assertIn("| r000-00000 | 162.50 | 0.50 | -1.25 | +0.00 | perforated | 160.0 | 1000 | – | – | – | – | 0.00 |", text)
        self.assertIn("| r000-00001 | 59.38 | – | – | – | stopped (turned back) | -0.4 |", text)
        self.assertIn("| r000-00002 | 42.19 | – | – | – | undecided at the end time | 22.3 |", text)
        # the bracket the entry gives is the table's too
        self.assertIn("V50 110.9 m/s (59.4–162.5)", text)
        self.assertNotIn("## layers-t", text)
        self.assertIn("## Not fired yet\n\n`layers-t`.", text)

    def test_a_shot_with_a_trace_shows_when_it_ended_and_its_breaks_by_mode_and_layer(self):
        import tempfile
        # the second shot's record keeps its energy balance, the first's (written before it was kept) does not
        fired = campaign("layers-t", FIXTURE_CASE, BISECTION,
                         [shot(212.5, "S", -0.1, 0), dict(shot(225.0, "P", 40.0, 1), energy_balance_error=0.0252)])
        with tempfile.TemporaryDirectory() as results, mock.patch.object(validation, "RESULTS", results):
            os.makedirs(os.path.join(results, "layers-t", "shots"))
            with open(validation.trace_path("layers-t", "r000-00000"), "w") as f:
                # layers out of order in the header, and past 9: read by number, not by name
                f.write("time_s,broken_tension,broken_shear,broken_combined,broken_layer_10,broken_layer_2,broken_layer_0\n"
                        "0,0,0,0,0,0,0\n1.344e-4,1307,108,357,0,629,511\n")
            # a trace without layer columns
            with open(validation.trace_path("layers-t", "r000-00001"), "w") as f:
                f.write("time_s,broken_tension,broken_shear,broken_combined\n2.5e-4,3,0,1\n")
            text = validation.shots_markdown([fired], [validation.entry(fired, [fired])])
        self.assertIn("| 1000 | 134.4 | 1307 / 108 / 357 | 511 / 629 / 0 | – | 0.00 |", text)
        self.assertIn("| 1000 | 250.0 | 3 / 0 / 1 | – | 2.52 | 0.00 |", text)


class Traces(unittest.TestCase):
    """A finished shot's trace: the projectile's course and the breaks from its run
    directory's history.csv, kept beside its record and committed with it."""

    HEADER = ["time_s", "projectile_position_x_m", "projectile_position_z_m", "projectile_velocity_x_m_s",
              "projectile_velocity_z_m_s", "projectile_angular_velocity_y_rad_s", "projectile_force_x_N", "projectile_force_z_N", "energy_total_J",
              "broken_tension", "broken_layer_0", "back_face_largest_m", "back_face_at_axis_m"]
    KEPT = ["time_s", "projectile_position_z_m", "projectile_velocity_x_m_s", "projectile_velocity_z_m_s",
            "projectile_angular_velocity_y_rad_s", "projectile_force_z_N", "energy_total_J", "broken_tension", "broken_layer_0",
            "back_face_at_axis_m"]

    def history(self, results, rows):
        directory = os.path.join(results, "layers-t", "shots", "r000-00000")
        os.makedirs(directory)
        with open(os.path.join(directory, "history.csv"), "w") as f:
            f.write(",".join(self.HEADER) + "\n")
            for i in range(rows):
                # digits a float formatter would not give back as written
                f.write(",".join(f"{i}.10000000000000001e-7" if k == 0 else str(i * 10 + k)
                                 for k in range(len(self.HEADER))) + "\n")

    def read(self, path):
        with open(path) as f:
            return [line.rstrip("\n").split(",") for line in f]

    def test_a_short_history_is_kept_whole_in_the_kept_columns_with_its_digits(self):
        import tempfile
        with tempfile.TemporaryDirectory() as results, mock.patch.object(validation, "RESULTS", results):
            self.history(results, 5)
            path = validation.write_trace("layers-t", "r000-00000")
            self.assertEqual(path, os.path.join(results, "layers-t", "shots", "r000-00000.trace.csv"))
            rows = self.read(path)
        self.assertEqual(rows[0], self.KEPT)
        self.assertEqual(len(rows), 6)
        self.assertEqual(rows[3], ["2.10000000000000001e-7", "22", "23", "24", "25", "27", "28", "29", "30", "32"])

    def test_a_history_with_a_short_row_is_refused_naming_its_line(self):
        import tempfile
        with tempfile.TemporaryDirectory() as results, mock.patch.object(validation, "RESULTS", results):
            self.history(results, 3)
            with open(os.path.join(results, "layers-t", "shots", "r000-00000", "history.csv"), "a") as f:
                f.write("1e-6,2,3\n")
            with self.assertRaises(SystemExit) as refused:
                validation.write_trace("layers-t", "r000-00000")
            self.assertFalse(os.path.exists(validation.trace_path("layers-t", "r000-00000")))
        self.assertIn("history.csv: line 5 has 3 fields where the header has 13", str(refused.exception))

    def test_a_long_history_is_thinned_evenly_keeping_its_first_and_last_rows(self):
        import tempfile
        with tempfile.TemporaryDirectory() as results, mock.patch.object(validation, "RESULTS", results):
            self.history(results, 2337)
            rows = self.read(validation.write_trace("layers-t", "r000-00000"))[1:]
        self.assertEqual(len(rows), validation.TRACE_ROWS)
        times = [float(r[0]) for r in rows]
        self.assertEqual(times[0], 0.10000000000000001e-7)
        self.assertEqual(rows[-1][0], "2336.10000000000000001e-7")
        gaps = {round((b - a) * 1e7) for a, b in zip(times, times[1:])}
        self.assertLessEqual(max(gaps) - min(gaps), 1)

    def test_a_shot_without_its_run_directory_has_no_trace_and_the_commit_leaves_it_out(self):
        import tempfile
        with tempfile.TemporaryDirectory() as results, mock.patch.object(validation, "RESULTS", results):
            os.makedirs(os.path.join(results, "layers-t", "shots"))
            self.assertIsNone(validation.write_trace("layers-t", "r000-00000"))
            self.history(results, 3)
            c = campaign("layers-t", FIXTURE_CASE, {"kind": "up_and_down"}, [at(212.5, "S", 0, 0)])
            # `summary` writes the trace a record lacks where its run directory is
            self.assertEqual(validation.write_missing_traces([c]),
                             [os.path.join(results, "layers-t", "shots", "r000-00000.trace.csv")])
            self.assertEqual(validation.write_missing_traces([c]), [])
            committed = []
            with mock.patch.object(validation, "git_commit_paths", lambda paths, *_: committed.extend(paths)):
                validation.commit(c, ["r000-00000"])
                os.remove(validation.trace_path("layers-t", "r000-00000"))
                with open(os.path.join(results, "layers-t", "shots", "r000-00000.json"), "w") as f:
                    f.write(validation.json.dumps(at(212.5, "S", 0, 0)))
                committed.append("--")
                validation.commit(c, ["r000-00000"])
        names = [os.path.basename(p) for p in committed]
        first, second = names[:names.index("--")], names[names.index("--") + 1:]
        self.assertIn("r000-00000.trace.csv", first)
        self.assertNotIn("r000-00000.trace.csv", second)
        self.assertIn("r000-00000.json", second)


class Status(unittest.TestCase):
    def priced(self, name, shots, whole):
        c = validation.Campaign.__new__(validation.Campaign)
        c.name, c.nodes, c.shots, c.planned, c.complete = name, 1000, shots, 4, False
        c.bound_core_hours, c.whole_core_hours, c.sibling_core_hours = 1.0, whole, None
        c.spec, c.case = {"design": {"kind": "up_and_down"}}, {"run": {"end_time_s": 2.5e-4}}
        return c

    def test_an_unstarted_series_is_priced_by_the_shots_of_its_siblings(self):
        # the element series fired two shots of 2 and 4 core-hours at the same mesh, design
        # kind and end time: the defaults' series is priced at their mean, not the model's 9
        element = self.priced("layers-12-t", [dict(shot(400.0, "P"), wall_s=3600.0, ranks=2),
                                              dict(shot(375.0, "S"), wall_s=7200.0, ranks=2)], 9.0)
        defaults = self.priced("layers-12-t-gauge", [], 9.0)
        longer = self.priced("layers-12-t-longer", [], 9.0)
        longer.case = {"run": {"end_time_s": 5e-4}}
        other_mesh = self.priced("layers-8-t", [], 9.0)
        other_mesh.nodes = 2000
        bisection = self.priced("layers-12-t-bisection", [], 9.0)
        bisection.spec = {"design": {"kind": "bisection"}}
        everyone = [element, defaults, longer, other_mesh, bisection]
        validation.price_by_siblings(everyone)
        self.assertEqual(defaults.per_shot_core_hours(), (3.0, "siblings"))
        self.assertEqual(element.per_shot_core_hours(), (3.0, "measured"))
        for apart in (longer, other_mesh, bisection):
            self.assertEqual(apart.per_shot_core_hours(), (9.0, "whole shots"), apart.name)
        printed = io.StringIO()
        with mock.patch.object(validation, "begun", lambda name: []), contextlib.redirect_stdout(printed):
            validation.status([defaults])
        self.assertIn("3.00 (s)", printed.getvalue().splitlines()[1])

    def test_an_unstarted_campaign_is_priced_by_whole_shots_of_its_kind_where_measured(self):
        measured = self.priced("panel-t", [], 1.98)
        never = self.priced("fibre-t", [], None)
        finished = self.priced("yarn-t", [dict(shot(50.0, "S"), wall_s=3600.0, ranks=2)], 0.5)
        self.assertEqual(measured.per_shot_core_hours(), (1.98, "whole shots"))
        self.assertEqual(never.per_shot_core_hours(), (1.0, "bound"))
        self.assertEqual(finished.per_shot_core_hours(), (2.0, "measured"))
        printed = io.StringIO()
        with mock.patch.object(validation, "begun", lambda name: []), contextlib.redirect_stdout(printed):
            validation.status([measured, never, finished])
        lines = printed.getvalue().splitlines()
        self.assertIn("1.98 (w)", lines[1])
        self.assertIn("1.00 (b)", lines[2])
        self.assertIn("2.00 (m)", lines[3])
        # 4 + 4 + 3 shots left at 1.98, 1.0 and 2.0 core-hours: 7.92 + 4 + 6
        self.assertIn("left: 11 shot(s), about 17.9 core-hours", lines[4])


class WholeShots(unittest.TestCase):
    """docs/benchmarks/whole-shots.json follows from the shot records, and says so when not."""

    def records(self, root, shots):
        directory = os.path.join(root, "validation", "panel-t", "shots")
        os.makedirs(directory)
        for k, (steps, wall_s) in enumerate(shots):
            with open(os.path.join(directory, f"r000-{k:05d}.json"), "w") as f:
                f.write(whole_shots.json.dumps({"id": f"r000-{k:05d}", "velocity_m_s": 200.0 + k,
                                                "steps": steps, "wall_s": wall_s, "ranks": 2}))

    def test_a_factor_is_the_measured_step_over_the_priced_one_and_an_edit_is_refused(self):
        with tempfile.TemporaryDirectory() as root, \
                mock.patch.object(whole_shots.validation, "RESULTS", os.path.join(root, "validation")), \
                mock.patch.object(whole_shots, "OUT", os.path.join(root, "whole-shots.json")), \
                mock.patch.object(whole_shots, "CAMPAIGNS", [("panel-t", "alone", True)]):
            self.records(root, [(1000, 90.0), (2000, 200.0)])
            shots = whole_shots.measured("panel-t", {"2": 0.05})
            self.assertEqual([s["factor"] for s in shots], [1.8, 2.0])
            entries = [{"campaign": "panel-t", "target_kind": "woven_panel", "conditions": "alone", "in_band": True,
                        "predicted_step_s": {"2": 0.05}, "shots": shots}]
            document = {"campaigns": entries, "bands": whole_shots.bands(entries)}
            self.assertEqual(document["bands"]["woven_panel"]["low"], 1.8)
            self.assertEqual(document["bands"]["woven_panel"]["high"], 2.0)
            with open(whole_shots.OUT, "w") as f:
                f.write(whole_shots.json.dumps(document))
            self.assertEqual(whole_shots.check(), [])
            document["campaigns"][0]["shots"][1]["factor"] = 1.5
            with open(whole_shots.OUT, "w") as f:
                f.write(whole_shots.json.dumps(document))
            problems = whole_shots.check()
            self.assertTrue(any("campaigns[0] (panel-t).shots" in p for p in problems), problems)
            self.assertTrue(any(p.startswith("bands") for p in problems), problems)

    def test_a_new_record_refreshes_its_campaign_in_the_file_with_the_price_it_holds(self):
        with tempfile.TemporaryDirectory() as root, \
                mock.patch.object(whole_shots.validation, "RESULTS", os.path.join(root, "validation")), \
                mock.patch.object(whole_shots, "OUT", os.path.join(root, "whole-shots.json")), \
                mock.patch.object(whole_shots, "CAMPAIGNS", [("panel-t", "alone", True)]):
            self.records(root, [(1000, 90.0)])
            entries = [{"campaign": "panel-t", "target_kind": "woven_panel", "conditions": "alone", "in_band": True,
                        "predicted_step_s": {"2": 0.05}, "shots": whole_shots.measured("panel-t", {"2": 0.05})}]
            with open(whole_shots.OUT, "w") as f:
                f.write(whole_shots.json.dumps({"campaigns": entries, "bands": whole_shots.bands(entries)}))
            # a campaign the script does not list, or records the file already follows: untouched
            self.assertIsNone(whole_shots.refresh("yarn-t"))
            self.assertIsNone(whole_shots.refresh("panel-t"))
            with open(os.path.join(root, "validation", "panel-t", "shots", "r000-00001.json"), "w") as f:
                f.write(whole_shots.json.dumps({"id": "r000-00001", "velocity_m_s": 201.0, "steps": 2000,
                                                "wall_s": 240.0, "ranks": 2}))
            self.assertEqual(whole_shots.check()[0][:30], "campaigns[0] (panel-t).shots: ")
            with contextlib.redirect_stderr(io.StringIO()) as said:
                self.assertEqual(whole_shots.refresh("panel-t"), whole_shots.OUT)
            self.assertIn("panel-t has 2 shot(s) now", said.getvalue())
            self.assertEqual(whole_shots.check(), [])
            with open(whole_shots.OUT) as f:
                document = whole_shots.json.load(f)
            self.assertEqual([s["factor"] for s in document["campaigns"][0]["shots"]], [1.8, 2.4])
            self.assertEqual(document["bands"]["woven_panel"]["high"], 2.4)
            # a shot on a rank count the file has no price for: left for --write, and said so
            with open(os.path.join(root, "validation", "panel-t", "shots", "r000-00002.json"), "w") as f:
                f.write(whole_shots.json.dumps({"id": "r000-00002", "velocity_m_s": 202.0, "steps": 2000,
                                                "wall_s": 240.0, "ranks": 1}))
            with contextlib.redirect_stderr(io.StringIO()) as said:
                self.assertIsNone(whole_shots.refresh("panel-t"))
            self.assertIn("no step priced on 1 rank(s)", said.getvalue())

    def test_the_commit_of_a_record_carries_the_refreshed_file(self):
        c = campaign("layers-t", FIXTURE_CASE, {"kind": "up_and_down"}, [at(212.5, "S", 0, 0)])
        committed = []
        with tempfile.TemporaryDirectory() as results, mock.patch.object(validation, "RESULTS", results):
            refreshed = os.path.join(results, "whole-shots.json")
            with open(refreshed, "w") as f:
                f.write("{}")
            with mock.patch.object(validation, "git_commit_paths", lambda paths, *_: committed.extend(paths)), \
                    mock.patch.object(validation, "refresh_whole_shots", lambda name: refreshed):
                validation.commit(c, ["r000-00000"])
            self.assertIn(refreshed, committed)
            committed.clear()
            with mock.patch.object(validation, "git_commit_paths", lambda paths, *_: committed.extend(paths)):
                # the real refresh: a campaign the whole-shots script does not list leaves the file alone
                validation.commit(c, ["r000-00000"])
            self.assertFalse(any(p.endswith("whole-shots.json") for p in committed), committed)


if __name__ == "__main__":
    unittest.main(verbosity=2)
