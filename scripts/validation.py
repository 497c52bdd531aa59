#!/usr/bin/env python3
"""The validation set against the seed's Table 6-1, run resumably, a shot at a time.

    scripts/validation.py status                      # what is done, what is left (begun here), its core-hours
    scripts/validation.py run [--ranks 2] [--max-shots N] [--only TEXT] [--commit]
    scripts/validation.py summary                     # rewrite validation/summary.json and shots.md, and the
                                                      # traces missing where run directories are here

Each campaign of `jobs/campaigns/validation/` runs into `validation/<campaign name>/`; a
finished shot leaves its record there (`shots/<id>.json`, written whole by `dea-mpi v50`),
and with `--commit` the record, the campaign's `v50.json` and `provenance.json` and
`validation/summary.json` are committed at once, one commit per shot. A later run on a fresh
checkout skips every shot on record and goes on with the next. Beside each record goes the
shot's trace (`shots/<id>.trace.csv`: the projectile's course and the breaks from its
history.csv, thinned to 400 rows), committed with it. An interrupted shot resumes
from its checkpoint when it is still on the machine (the run directories `shots/<id>/` are
not committed), otherwise it starts again. SIGTERM or SIGUSR1 to this script (not to its
`mpirun`, which on SIGTERM kills its ranks and exits 1, losing the shot) is passed on to `mpirun`
as SIGUSR1: the shot checkpoints (at its first step, if it was still being set up) and the script
ends with 75 without firing another. A campaign's last shot undecided at its
end time, when the campaign's end time has since been raised and the shot's checkpoint is
still on the machine, has its record withdrawn and goes on from there (`held_to_take_on`).

Campaigns run cheapest first. The estimate of what is left is, per shot, the mean cost of the
campaign's finished shots (wall time x ranks) when it has any ("m"), otherwise that of the
finished shots of campaigns at the same mesh with the same kind of design and end time
("s": a series that changes only a model or the speeds), otherwise the price
`dea-mpi check --ranks R` gives a shot (the cost model calibrated on the reference shot,
docs/theory.md C1: steps to the end time after the settle at the reference window's rates)
times the highest factor whole shots of its target's kind have cost over that price ("w",
docs/benchmarks/whole-shots.json: woven panels near their limit cost more per step than the
window, a single yarn less), or the bare price where no such shot was measured ("b"). Shots
stop when decided, so most take fewer steps than the end time's. Walls of shots fired
beside another loop before 2026-11-28 overstate their cost (docs/validation.md).

`validation/summary.json` lists one entry per campaign (docs/validation.md, "Table 6-1 at
laboratory scale", says what each field means); `validation/shots.md` every shot on record,
campaign by campaign, as tables.
"""
import argparse
import csv
import glob
import importlib.util
import json
import os
import re
import signal
import subprocess
import sys
import time
import types

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAMPAIGNS = os.path.join(ROOT, "jobs", "campaigns", "validation")
RESULTS = os.path.join(ROOT, "validation")

# The seed's Table 6-1 (17-grain FSP on KM2 shoot packs, mu = 0.3): V50 [m/s] by layers.
TABLE_6_1_EXPERIMENT = {4: 245.0, 8: 287.0, 12: 416.0, 16: 441.0, 20: 511.0, 24: 506.0, 28: 549.0}
TABLE_6_1_MODIFIED_DEA = {1: 135.0, 4: 305.0, 8: 407.0, 12: 435.0, 16: 475.0, 20: 505.0, 24: 525.0, 28: 545.0}
# The seed's Table 5-2 (single 0.4 k KM2 yarn, 5.56 mm cylinder, mu = 0.3): V50 [m/s] by
# digital fibres per yarn, with I = I0 and I = I_inf (the k1 = 0.8 value lies between).
TABLE_5_2_I0 = {4: 255.0, 16: 215.0, 36: 185.0, 64: 155.0, 100: 135.0, 144: 125.0, 196: 115.0}
TABLE_5_2_I_INF = {4: 45.0, 16: 45.0, 36: 55.0, 64: 78.0, 100: 85.0, 144: 95.0, 196: 95.0}
# The seed's Table 5-3: V50 [m/s] of the 64-digital-fibre yarn with I = I0 by inter-fibre
# friction coefficient (its basis for k2 = 1).
TABLE_5_3_I0_64 = {0.3: 155.0, 0.5: 147.0, 0.7: 143.0, 1.0: 125.0, 2.0: 125.0}


def binary(args):
    return args.binary or os.path.join(ROOT, "target", "release", "dea-mpi")


def series_of(name):
    for prefix, series in (("panel-", "panel_size"), ("mesh-", "mesh"), ("layers-", "layers"), ("yarn-", "single_yarn"),
                           ("low-end-yarn-", "single_yarn_low_end"), ("low-end-", "panel_size_low_end")):
        if name.startswith(prefix):
            return series
    return "other"


def bisection_bounds(design, shots):
    """The design's [low, high] once the shots are seen, as dea_ballistic::design's
    bisection_bounds moves them: a low bound some shot at or below perforated halves (not
    below the resolution), a high bound some shot at or above did not perforate doubles (not
    above 8 x high) [m/s]."""
    low, high, resolution = design["low_m_s"], design["high_m_s"], design["resolution_m_s"]
    ceiling = 8.0 * high
    while low > resolution and any(s["perforated"] and s["velocity_m_s"] <= low for s in shots):
        low = max(0.5 * low, resolution)
    while high < ceiling and any(not s["perforated"] and s["velocity_m_s"] >= high for s in shots):
        high = min(2.0 * high, ceiling)
    return low, high


def bisection_bracket(design, shots):
    """(highest partial, lowest complete) within the bisection's bounds [m/s]."""
    low, high = bisection_bounds(design, shots)
    for s in shots:
        if s["perforated"]:
            high = min(high, s["velocity_m_s"])
        else:
            low = max(low, s["velocity_m_s"])
    return low, high


def records(name):
    shots = []
    for path in sorted(glob.glob(os.path.join(RESULTS, name, "shots", "*.json"))):
        with open(path) as f:
            shots.append(json.load(f))
    return shots


# what `dea-mpi check` printed, by all it depends on but docs/benchmarks/whole-shots.json
# (which moves only the price of an unstarted campaign): a run loads every campaign again
# after each shot to write the summary, and checking them all again (a panel's check builds
# it to count its nodes) took longer than a small campaign's shot
CHECKED = {}


def check(args, campaign_path):
    """What `dea-mpi check` says of a campaign file, asked once in a process for each content
    of the file, binary (by its path and modification time) and rank count."""
    try:
        with open(campaign_path) as f:
            text = f.read()
        built = os.stat(binary(args)).st_mtime_ns
    except OSError:
        return json.loads(check_now(args, campaign_path))
    key = (binary(args), built, args.ranks, os.path.abspath(campaign_path), text)
    if key not in CHECKED:
        CHECKED[key] = check_now(args, campaign_path)
    return json.loads(CHECKED[key])


def check_now(args, campaign_path):
    command = [binary(args), "check", campaign_path, "--ranks", str(args.ranks)]
    try:
        done = subprocess.run(command, capture_output=True, text=True)
    except OSError as error:
        # every campaign is checked before anything else runs, so this is where a missing
        # or unbuilt binary first shows
        how = "" if args.binary else ": build it (`cargo build --release`, or scripts/setup.sh), or name one with --binary"
        sys.exit(f"validation.py: cannot run dea-mpi {command[0]} ({error.strerror}){how}")
    if done.returncode != 0:
        sys.exit(f"{campaign_path}: dea-mpi check failed:\n{done.stderr.strip()}")
    return done.stdout


class Campaign:
    def __init__(self, args, path):
        self.path = path
        # the dea-mpi that fires its shots and fits pooled series (`fit`)
        self.binary = binary(args)
        with open(path) as f:
            self.spec = json.load(f)
        self.name = self.spec["name"]
        checked = check(args, path)
        self.case = checked["case"]
        resolved = checked["resolved"]
        self.nodes = resolved["nodes"]
        self.bound_core_hours = resolved["cost"]["core_hours"]
        # the price times the highest factor measured on whole shots of this target's kind
        whole = resolved["cost"].get("whole_shots")
        self.whole_core_hours = whole["core_hours_high"] if whole else None
        # the shots check prices the design at (dea_ballistic::Design::expected_shots)
        self.planned = resolved["cost"]["campaign"]["shots"]
        # the mean cost of finished shots fired at the same mesh by the same kind of design to
        # the same end time in other campaigns (`price_by_siblings`), None where there are none
        self.sibling_core_hours = None
        self.refresh()

    def refresh(self):
        self.shots = records(self.name)
        self.complete = self.finished_design()

    def finished_design(self):
        design = self.spec["design"]
        if design["kind"] == "bisection":
            # narrow enough, and both ends stand on shots (the engine fires a bound it rests on)
            low, high = bisection_bracket(design, self.shots)
            fired = {s["velocity_m_s"] for s in self.shots}
            return high - low <= design["resolution_m_s"] and low in fired and high in fired
        return len(self.shots) >= self.planned

    def per_shot_core_hours(self):
        if self.shots:
            return sum(s["wall_s"] * s["ranks"] for s in self.shots) / len(self.shots) / 3600.0, "measured"
        if self.sibling_core_hours is not None:
            return self.sibling_core_hours, "siblings"
        if self.whole_core_hours is not None:
            return self.whole_core_hours, "whole shots"
        return self.bound_core_hours, "bound"

    def left(self):
        return 0 if self.complete else max(1, self.planned - len(self.shots))


def siblings(c, campaigns):
    """The other campaigns that fire at `c`'s mesh (as many nodes) with the same kind of
    design and the same end time: a series that changes only the failure or friction model
    or the speeds (the 12-layer series under today's defaults beside the element series)."""
    def key(k):
        return (k.nodes, k.spec["design"]["kind"], k.case["run"].get("end_time_s"))
    return [o for o in campaigns if o is not c and key(o) == key(c)]


def price_by_siblings(campaigns):
    """Prices each campaign without finished shots by the mean cost of its siblings' finished
    shots (`siblings`). The cost model's whole-shot price runs every shot to the end time at
    the dearest factor measured, an upper figure (8.4 core-hours a shot for the 12-layer
    series whose element twin cost 2.9 a shot); shots stop when decided, and a sibling's
    shots stop much where this one's will. Series under other failure models cost within
    about a fifth of each other (the 8-layer series: 3.1 against 2.6 core-hours a shot)."""
    for c in campaigns:
        fired = [s for o in siblings(c, campaigns) for s in o.shots]
        c.sibling_core_hours = (sum(s["wall_s"] * s["ranks"] for s in fired) / len(fired) / 3600.0
                                if fired and not c.shots else None)


def load(args):
    paths = sorted(glob.glob(os.path.join(CAMPAIGNS, "*.json")))
    campaigns = [Campaign(args, p) for p in paths]
    # priced against every campaign, not only those --only keeps
    price_by_siblings(campaigns)
    if args.only:
        campaigns = [c for c in campaigns if args.only in c.name]
    # cheapest first: the small results come early, the long runs after
    return sorted(campaigns, key=lambda c: (c.per_shot_core_hours()[0], c.name))


def resumable(directory):
    """Whether a shot's run directory holds a checkpoint to go on from (a checkpoint is
    renamed into place only once complete, docs/output.md)."""
    return os.path.exists(os.path.join(directory, "checkpoint", "manifest.h5"))


# progress.json of a shot that is stepping is rewritten every few tens of seconds (or at
# each checkpoint); one in state "running" left alone longer than this was stopped without
# a word (SIGKILL, a lost node): a signal's checkpoint stop writes state "interrupted"
RUNNING_WITHIN_S = 180.0


def begun(name, now=None):
    """The shots of campaign `name` begun on this machine and not on record: [(id, simulated
    time [s], end time [s], whether a checkpoint is there to go on from, its simulated time
    [s] or None where progress.json does not say, whether it is stepping now)], from each run
    directory's progress.json (rank 0 rewrites it as the shot runs, and names each checkpoint
    it writes; state "running" and rewritten within RUNNING_WITHIN_S of `now`: stepping)."""
    now = time.time() if now is None else now
    found = []
    for directory in sorted(glob.glob(os.path.join(RESULTS, name, "shots", "r*-*"))):
        shot_id = os.path.basename(directory)
        if not os.path.isdir(directory) or os.path.exists(directory + ".json"):
            continue
        try:
            with open(os.path.join(directory, "progress.json")) as f:
                progress = json.load(f)
            time_s, end_s = float(progress["simulated_time_s"]), float(progress["end_time_s"])
            checkpoint_s = progress.get("checkpoint_time_s")
            checkpoint_s = None if checkpoint_s is None else float(checkpoint_s)
            age_s = now - os.path.getmtime(os.path.join(directory, "progress.json"))
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            continue
        running = progress.get("state") == "running" and age_s < RUNNING_WITHIN_S
        found.append((shot_id, time_s, end_s, resumable(directory), checkpoint_s, running))
    return found


def begun_words(shots):
    """What `status` says of the shots `begun` gave."""
    def goes_on(resumable, checkpoint_s, running):
        if running:
            return "stepping now"
        if not resumable:
            return "no checkpoint: starts again"
        if checkpoint_s is None:
            return "goes on from its checkpoint"
        return f"goes on from its checkpoint at {1e6 * checkpoint_s:.1f} us"
    return "; ".join(f"{shot_id} at {1e6 * time_s:.1f} of {1e6 * end_s:.0f} us, " + goes_on(resumable, checkpoint_s, running)
                     for shot_id, time_s, end_s, resumable, checkpoint_s, running in shots)


def status(campaigns):
    total = 0.0
    # the name column as wide as the longest name, so that every row's figures line up
    width = max([len("campaign")] + [len(c.name) for c in campaigns])
    print(f"{'campaign':<{width}} {'nodes':>9} {'shots':>7} {'left':>5} {'core-h/shot':>12}  state")
    for c in campaigns:
        per_shot, how = c.per_shot_core_hours()
        total += c.left() * per_shot
        state = "complete" if c.complete else "to run"
        started = begun(c.name)
        if started and not c.complete:
            state += f" ({begun_words(started)})"
        print(f"{c.name:<{width}} {c.nodes:>9} {len(c.shots):>3}/{c.planned:<3} {c.left():>5} {per_shot:>8.2f} ({how[0]}) {state}")
    print(f"left: {sum(c.left() for c in campaigns)} shot(s), about {total:.1f} core-hours")
    print("  m: the mean of the campaign's finished shots; s: the mean of the finished shots of campaigns\n"
          "  at the same mesh with the same kind of design and end time; w: the cost model's price to the\n"
          "  end time times the highest factor whole shots of its kind have cost\n"
          "  (docs/benchmarks/whole-shots.json); b: the bare price, for a kind never measured")


def same_shot_but_speed(case, other):
    """Whether two cases fire the same shot but for its striking speed and end time."""
    def bare(c):
        c = json.loads(json.dumps(c))
        c.pop("name", None)
        c.pop("run", None)
        c.get("projectile", {}).pop("velocity_m_s", None)
        return c
    return bare(case) == bare(other)


def re_fires(c, other):
    """Whether `other` is a low-end campaign of `c`: the same case but for the speed and the
    end time (`same_shot_but_speed`), of the low-end series of `c`'s (a panel-size bisection's
    or a single-yarn one's). Two meshes of one panel size are two targets: a low-end shot of
    the one never joins the other's bisection."""
    low_end = {"single_yarn": "single_yarn_low_end", "panel_size": "panel_size_low_end"}.get(series_of(c.name))
    return low_end is not None and series_of(other.name) == low_end and same_shot_but_speed(c.case, other.case)


def refired(c, campaigns):
    """The shots of `c`, a panel-size or single-yarn bisection, with those of its low-end
    campaigns ([`re_fires`]): a low-end shot replaces one of `c` undecided at the
    end time at its velocity (fired again with a longer end time), or, at a velocity `c`
    did not fire, extends the bisection below its slowest shot; and a note of each for the
    method."""
    shots, notes = list(c.shots), []
    for other in sorted((o for o in campaigns if re_fires(c, o)), key=lambda o: o.name):
        for again in sorted(other.shots, key=lambda s: s["id"]):
            same = [s for s in shots if s["velocity_m_s"] == again["velocity_m_s"]]
            held = [s for s in same if not s["perforated"] and s["stopped_by"] == "end_time_s"]
            if (same and not held) or (held and again["stopped_by"] == "end_time_s"):
                continue
            shots = [s for s in shots if s not in held] + [again]
            outcome = (f"perforated ({again['residual_velocity_m_s']:.1f} m/s left)" if again["perforated"]
                       else "undecided at its end time" if again["stopped_by"] == "end_time_s" else "stopped")
            # a low-end campaign without a fixed scatter draws its own aim and yaw: then it is
            # not the same shot, and the note says so
            drawn = [again.get("aim_offset_m", [0.0, 0.0]), again.get("yaw_deg", 0.0), again.get("obliquity_deg", 0.0)]
            if drawn != [[0.0, 0.0], 0.0, 0.0]:
                x, y = (1e3 * a for a in drawn[0])
                outcome += (f" (a different shot: it drew its aim {x:+.2f}, {y:+.2f} mm off and {drawn[1]:+.2f} deg "
                            f"of yaw, {drawn[2]:+.2f} deg of obliquity)")
            if held:
                notes.append(f"the {again['velocity_m_s']:.1f} m/s shot, undecided at the end time, fired again by "
                             f"{other.name} with a longer one: {outcome}")
            else:
                notes.append(f"a {again['velocity_m_s']:.1f} m/s shot fired by {other.name}: {outcome}")
    return shots, notes


def campaign_report(c):
    """The estimates from the campaign's shots on record, by this dea-mpi (`dea-mpi fit` of its
    directory, so that every entry's fits are this binary's, whichever fired the shots), or
    None before its first shot."""
    if not c.shots or not os.path.exists(os.path.join(RESULTS, c.name, "provenance.json")):
        return None
    return fit_pooled(c, [])


def entry(c, campaigns=(), report=None):
    """One campaign's line of validation/summary.json."""
    target = c.case["target"]
    weave = target.get("weave") or {}
    hybrid = target.get("hybrid") or {}
    layers = target.get("layers", 1)
    design = c.spec["design"]
    v50 = low = high = below = above = None
    # a bracket's low end: whether it rests on a decided partial (not only on shots still
    # moving at their end time)
    established = None
    method = None
    if design["kind"] == "bisection":
        shots, notes = refired(c, campaigns) if series_of(c.name) in ("panel_size", "single_yarn") else (c.shots, [])
        lo, hi = bisection_bracket(design, shots)
        has_partial = any(not s["perforated"] for s in shots)
        has_complete = any(s["perforated"] for s in shots)
        if has_partial and has_complete:
            v50, low, high = 0.5 * (lo + hi), lo, hi
            method = "bisection bracket (highest partial, lowest complete)"
            held = [s for s in shots if not s["perforated"] and s["velocity_m_s"] == lo and s["stopped_by"] == "end_time_s"]
            established = not held
            if held:
                method += (f"; the partial at {lo:.1f} m/s was undecided at the end time (still moving at "
                           f"{held[0]['residual_velocity_m_s']:.1f} m/s), so the bracket's low end is not established")
        elif shots:
            method = "bisection: no bracket yet (" + ("all perforated" if has_complete else "none perforated") + ")"
            if has_complete:
                below = min(s["velocity_m_s"] for s in shots)
            elif all(s["stopped_by"] != "end_time_s" for s in shots):
                # every shot turned back or came to rest (none only held at its end time)
                above = max(s["velocity_m_s"] for s in shots)
        method = "; ".join([method] + notes) if method else method
    elif design["kind"] == "velocities":
        method = "residual velocity at a fixed striking speed"
    elif (report := report if report is not None else campaign_report(c)) is not None:
        fit = report.get("logistic", {})
        # Firth's penalised logistic (docs/theory.md V11), which has an estimate where the
        # outcomes separate. Its interval is quoted only where the outcomes mix at some speed,
        # which pins the limit (with none, the shots allow any limit between the highest partial
        # and the lowest complete, and an interval narrower than that is the penalty's, not
        # theirs), and where it lies within the speeds fired (beyond them it rests on the
        # logistic shape rather than on shots)
        firth = report.get("firth_logistic", {}).get("Ok", {}).get("v50")
        speeds = [s["velocity_m_s"] for s in c.shots]
        partials = [s["velocity_m_s"] for s in c.shots if not s["perforated"]]
        completes = [s["velocity_m_s"] for s in c.shots if s["perforated"]]
        outcomes_mix = bool(partials and completes) and max(partials) >= min(completes)

        def profile_within_speeds(estimate):
            # a profile interval with both ends, inside the slowest and fastest speeds fired
            ends = None if estimate is None else (estimate.get("profile_low"), estimate.get("profile_high"))
            return ends is not None and None not in ends and min(speeds) <= ends[0] and ends[1] <= max(speeds)
        firth_bounded = profile_within_speeds(firth)
        # the maximum-likelihood logistic's delta-method interval is a normal approximation;
        # with few shots the likelihood is far from normal, which its profile interval shows by
        # reaching beyond the speeds fired (or having no end): then the shots do not fix the
        # curve's slope and the narrow delta interval is not theirs, so it is not quoted
        ml = fit.get("Ok", {}).get("v50")
        if profile_within_speeds(ml):
            v50, low, high = ml["velocity"], ml["low"], ml["high"]
            method = "logistic maximum likelihood, 95 % interval (delta method)"
        elif firth_bounded and outcomes_mix:
            v50, low, high = firth["velocity"], firth["profile_low"], firth["profile_high"]
            method = ("Firth's penalised logistic, 95 % profile penalised-likelihood interval (docs/theory.md V11); "
                      "the maximum-likelihood logistic has none: " + str(fit.get("Err", "no fit")))
            undecided = [s for s in c.shots if not s["perforated"] and s["stopped_by"] == "end_time_s"]
            established = not undecided
            if undecided:
                method += (f"; {len(undecided)} partial(s) were undecided at the end time and count as partials, "
                           f"so the interval's low end is not established")
        else:
            if ml is not None:
                def end(v):
                    return "no end" if v is None else f"{v:.1f}"
                reason = (f"its V50 {ml['velocity']:.1f} m/s has a 95 % delta-method interval of {ml['low']:.1f}–"
                          f"{ml['high']:.1f} m/s, but its profile-likelihood interval ({end(ml.get('profile_low'))} to "
                          f"{end(ml.get('profile_high'))} m/s) reaches beyond the speeds fired ({min(speeds):.1f}–"
                          f"{max(speeds):.1f} m/s): too few shots to fix the curve's slope")
            else:
                reason = str(fit.get("Err", "no fit"))
            method = "logistic: " + reason
            # without a fit, MIL-STD-662F's mean within the bracket of the highest partial and
            # the lowest complete penetration, which is its range; when outcomes mix only where
            # the logistic still has no maximum (both at one speed: quasi-complete separation),
            # the bracket is the nearest speeds below and above the mixed ones that went one way
            mil = report.get("mil_std_662f", {})
            if partials and completes:
                # without mixing these are the highest partial and the lowest complete
                zone = (min(completes), max(partials))
                low = max((v for v in partials if v < zone[0]), default=zone[0])
                high = min((v for v in completes if v > zone[1]), default=zone[1])
                mixed = zone[1] >= zone[0]
                bracket_words = "the bracket (highest partial, lowest complete)"
                midpoint_words = "bracket (highest partial, lowest complete) and its midpoint"
                if mixed:
                    at = f"{zone[0]:.1f} m/s" if zone[0] == zone[1] else f"{zone[0]:.1f}–{zone[1]:.1f} m/s"
                    # where nothing one-way was fired beyond the mixed speeds, the range
                    # ends at them, and the words say so rather than call them one-way
                    beyond = [side for side, end, edge in (("below", low, zone[0]), ("above", high, zone[1]))
                              if end == edge]
                    bracket_words = (f"the nearest speeds with one outcome around those that mix ({at}): "
                                     f"{low:.1f}–{high:.1f} m/s"
                                     + "".join(f" (none {side}: the range ends at the mixed speed)" for side in beyond))
                    midpoint_words = f"{bracket_words[0].upper()}{bracket_words[1:]}, and its midpoint"
                # a low end resting only on shots still moving at the end time is not established
                at_low = [s for s in c.shots if not s["perforated"] and s["velocity_m_s"] >= low]
                established = any(s["stopped_by"] != "end_time_s" for s in at_low)
                mean = mil["Ok"]["v50"] if "Ok" in mil else None
                if mean is not None and low <= mean <= high:
                    v50 = mean
                    method = (f"MIL-STD-662F mean of the {mil['Ok']['count']} highest partials and lowest complete "
                              f"penetrations, within {bracket_words}; no interval: " + method)
                else:
                    # too few shots for MIL-STD-662F, or its mean outside the bracket (partials
                    # reaching far below a high one near the lowest complete): the bracket still
                    # bounds the limit
                    why = (f"MIL-STD-662F's mean of the {mil['Ok']['count']} highest partials and lowest complete "
                           f"penetrations, {mean:.1f} m/s, falls outside it" if mean is not None
                           else f"no MIL-STD-662F: {mil.get('Err', 'no estimate')}")
                    v50 = 0.5 * (low + high)
                    method = f"{midpoint_words}; {why}; no interval: " + method
                if not established:
                    method += (f"; every partial at {low:.1f} m/s was undecided at the end time, so the "
                               f"bracket's low end is not established")
            elif completes:
                # every shot perforated: V50 lies below the slowest, as for a bisection
                below = min(completes)
                method += f"; every shot perforated: V50 lies below {below:.1f} m/s"
            elif partials and all(s["stopped_by"] != "end_time_s" for s in c.shots):
                # every shot stopped, each decided: V50 lies above the fastest
                above = max(partials)
                method += f"; every shot stopped: V50 lies above {above:.1f} m/s"
            if firth is not None:
                ends = " to ".join("unbounded" if e is None else f"{e:.1f}" for e in (firth["profile_low"], firth["profile_high"]))
                method += (f"; Firth's penalised logistic gives V50 {firth['velocity']:.1f} m/s, but its 95 % interval "
                           f"({ends} m/s) " + (f"reaches beyond the speeds fired ({min(speeds):.1f}–{max(speeds):.1f} m/s)"
                                               if not firth_bounded else
                                               "is the penalty's rather than the shots': no speed holds both outcomes"))
    series = series_of(c.name)
    fibres = weave.get("fibres_per_yarn") or target.get("fibres_per_yarn")
    if series in ("single_yarn", "single_yarn_low_end"):
        experiment, seed_dea = None, None
        mu = c.case["contact"].get("friction_coefficient")
        free = (c.case.get("bending") or {}).get("model") == "free"
        seed_reference = {"table_5_2_i0_m_s": TABLE_5_2_I0.get(fibres), "table_5_2_i_inf_m_s": TABLE_5_2_I_INF.get(fibres),
                          "bending": c.case.get("bending"), "friction_coefficient": mu,
                          "table_5_3_m_s": TABLE_5_3_I0_64.get(mu) if fibres == 64 and free else None}
    else:
        experiment, seed_dea = TABLE_6_1_EXPERIMENT.get(layers), TABLE_6_1_MODIFIED_DEA.get(layers)
        seed_reference = None
    provenance_path = os.path.join(RESULTS, c.name, "provenance.json")
    commit = None
    if os.path.exists(provenance_path):
        with open(provenance_path) as f:
            commit = json.load(f).get("git_commit")
    fine_ratio = weave.get("element_length_ratio") or target.get("element_length_ratio") or 0.5
    out = {
        "name": c.name,
        "series": series,
        "layers": layers,
        "side_m": target.get("side_m") or target.get("length_m"),
        "fibres_per_yarn": fibres,
        "fine_radius_m": hybrid.get("fine_radius_m"),
        "coarse_fibres_per_yarn": hybrid.get("fibres_per_yarn"),
        "element_length_ratio": fine_ratio,
        # the coarse yarns' own l0/d (hybrid.element_length_ratio; absent: the fine one's)
        "coarse_element_length_ratio": (hybrid.get("element_length_ratio") or fine_ratio) if hybrid else None,
        # the coarse yarns stepped at their own, longer step (run.multi_rate, docs/theory.md T1)
        "multi_rate": bool(c.case["run"].get("multi_rate")),
        "projectile": c.case["projectile"].get("preset") or c.case["projectile"].get("shape"),
        # how the fibre-projectile friction spring kept its stretch (docs/theory.md I6c)
        "projectile_friction_spring": c.case["contact"].get("projectile_friction_spring") or "rotating",
        # and the fibre-fibre one (docs/theory.md I6d)
        "fibre_friction_spring": c.case["contact"].get("fibre_friction_spring") or "anchored",
        # and when broken elements stop acting (docs/theory.md I7)
        "unload": (c.case.get("failure") or {}).get("unload") or "at_break",
        # what a crimped spring stores below its rest angle (docs/theory.md F4b): "smooth"
        # unless named on a woven panel whose springs rest bent; where every spring rests
        # straight the laws coincide and the solver reports "cone"
        "rest_angle_law": target.get("rest_angle_law") or ("smooth" if rests_bent(target) else "cone"),
        # how the failure criterion measures tension (docs/theory.md I9c), "gauge" unless named
        "tension_measure": (c.case.get("failure") or {}).get("tension_measure") or "gauge",
        # and shear (docs/theory.md I9b), "gauge" unless named
        "shear_measure": (c.case.get("failure") or {}).get("shear_measure") or "gauge",
        "shots": len(c.shots),
        "complete": c.complete,
        "v50_m_s": v50,
        "v50_low_m_s": low,
        "v50_high_m_s": high,
        # a bracket whose low end was still moving at its end time: false
        "v50_low_established": established,
        # a bisection whose every shot perforated (re-fired shots counted): V50 lies below this
        "v50_below_m_s": below,
        # a bisection whose every shot was stopped, each decided: V50 lies above this
        "v50_above_m_s": above,
        "method": method,
        "experiment_m_s": experiment,
        "seed_dea_m_s": seed_dea,
        "shot_records": [
            {k: s[k] for k in ("id", "velocity_m_s", "perforated", "residual_velocity_m_s", "stopped_by", "steps", "wall_s", "ranks")}
            for s in sorted(c.shots, key=lambda s: s["id"])
        ],
        "core_hours": round(sum(s["wall_s"] * s["ranks"] for s in c.shots) / 3600.0, 3),
        "git_commit": commit,
    }
    if seed_reference:
        out["seed_reference"] = seed_reference
    return out


def rests_bent(target):
    """Whether a case's target has springs bent at rest: a woven panel woven "as_woven" (the
    default) or read from a cell file, which carries its rest angles (Case::takes_rest_angle_law)."""
    woven = target.get("kind") in ("woven_panel", "three_d_woven_panel")
    crimped = (target.get("weave") or {}).get("bending_at_rest", "as_woven") != "straight"
    return woven and (bool(target.get("cell_file")) or crimped)


def step_of(name):
    """The step [m/s] of a campaign named `<name>-step-<m/s>`, else None."""
    found = re.fullmatch(r".+-step-([0-9.]+)", name)
    return float(found.group(1)) if found else None


def step_pools(campaigns):
    """(coarse, [finer, ...]) groups: a campaign named `<name>-step-<m/s>` with shots on
    record is a finer series about the bracket of the campaign `<name>`, and all of them are
    pooled with it (docs/theory.md V10), coarsest step first."""
    by_name = {c.name: c for c in campaigns}
    groups = {}
    for c in campaigns:
        found = re.fullmatch(r"(.+)-step-[0-9.]+", c.name)
        if found and found.group(1) in by_name and c.shots:
            groups.setdefault(found.group(1), []).append(c)
    return [(by_name[name], sorted(finer, key=lambda c: -step_of(c.name))) for name, finer in sorted(groups.items())]


def fit_pooled(coarse, finer):
    """`dea-mpi fit --json` of the campaigns' directories (`coarse`, then each of `finer`):
    their estimates together."""
    names = [coarse.name] + [c.name for c in finer]
    command = [coarse.binary, "fit"] + [os.path.join(RESULTS, name) for name in names] + ["--json"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' and '.join(names)}: `{' '.join(command)}` failed (exit {done.returncode}; "
                 f"`fit` is in dea-mpi since 030b8aa):\n{done.stderr.strip()}")
    return json.loads(done.stdout)


def pooled_entry(coarse, finer, campaigns, report):
    """The summary entry of several series of one target pooled: the estimates `report` of
    `dea-mpi fit`, the pooled shots, named `<coarse> + step-<m/s> [+ step-<m/s> ...]`; its
    core-hours are the pooled campaigns' own entries'."""
    name = " + ".join([coarse.name] + [c.name[len(coarse.name) + 1:] for c in finer])
    pooled = types.SimpleNamespace(name=name, case=coarse.case, shots=report["shots"],
                                   spec={"name": name, "design": {"kind": "pooled"}},
                                   complete=coarse.complete and all(c.complete for c in finer))
    out = entry(pooled, campaigns, report)
    out["pooled_from"] = [coarse.name] + [c.name for c in finer]
    out["core_hours"] = None
    out["git_commit"] = None
    return out


def write_summary(campaigns):
    """Writes validation/summary.json and, from the same entries, validation/shots.md."""
    os.makedirs(RESULTS, exist_ok=True)
    ordered = sorted(campaigns, key=lambda c: c.name)
    entries = [entry(c, campaigns) for c in ordered]
    entries += [pooled_entry(coarse, finer, campaigns, fit_pooled(coarse, finer)) for coarse, finer in step_pools(ordered)]
    path = os.path.join(RESULTS, "summary.json")
    with open(path + ".partial", "w") as f:
        json.dump(entries, f, indent=1)
        f.write("\n")
    os.replace(path + ".partial", path)
    tables = os.path.join(RESULTS, "shots.md")
    with open(tables + ".partial", "w") as f:
        f.write(shots_markdown(ordered, entries))
    os.replace(tables + ".partial", tables)
    return path


def outcome_words(s):
    """What a shot record says happened, in the words of docs/theory.md V1."""
    if s["perforated"]:
        return "perforated"
    if s["stopped_by"] == "end_time_s":
        return "undecided at the end time"
    return "stopped (turned back)"


def design_words(design):
    kind = design["kind"]
    if kind == "bisection":
        return f"bisection from [{design['low_m_s']:g}, {design['high_m_s']:g}] m/s to {design['resolution_m_s']:g} m/s"
    if kind == "up_and_down":
        return (f"up-and-down from {design['start_m_s']:g} m/s by {design['step_m_s']:g} m/s, "
                f"{design['shots']} shot{'' if design['shots'] == 1 else 's'} planned")
    if kind == "velocities":
        return "fixed striking speeds " + ", ".join(f"{v:g}" for v in design["velocities_m_s"]) + " m/s"
    return kind.replace("_", " ")


def shots_markdown(campaigns, entries):
    """Every shot on record, campaign by campaign, as tables (validation/shots.md): what each
    shot drew, what happened to it and what it cost, read from the records so that no shot is
    transcribed by hand. Shots are listed in the order they were fired."""
    lines = ["# Validation shots", "",
             "Written by `scripts/validation.py` (run, summary) from the records in "
             "`validation/<campaign>/shots/`; do not edit. What the campaigns compare and what the results "
             "say is in docs/validation.md. *Aim* is the aim point's distance from the panel's centre as "
             "drawn (the scatter of the campaign file), *left* the projectile's speed when the shot ended "
             "(for a stopped shot, about zero or slightly negative: it turned back), *core-h* the wall time "
             "times ranks (walls of shots fired beside another loop before 2026-11-28 overstate it, "
             "docs/validation.md), *ended* the simulated time of the shot's last trace row, *breaks* the "
             "elements broken by then in tension, shear and combined failure (docs/theory.md I10) and by layer, struck "
             "face first (\"–\" for shots fired before traces were kept). Campaigns with no shot yet are listed at "
             "the end.", ""]
    waiting = []
    for c, e in zip(campaigns, entries):
        if not c.shots:
            waiting.append(c.name)
            continue
        state = "complete" if c.complete else "in progress"
        lines.append(f"## {c.name}")
        lines.append("")
        described = f"{design_words(c.spec['design'])}; {len(c.shots)} on record, {state}."
        if e["v50_m_s"] is not None:
            described += (f" V50 {e['v50_m_s']:.1f} m/s ({e['v50_low_m_s']:.1f}–{e['v50_high_m_s']:.1f}): "
                          f"{e['method']}.")
        elif e["method"]:
            described += f" {e['method'][0].upper()}{e['method'][1:]}."
        lines.append(described)
        lines.append("")
        lines.append("| shot | striking (m/s) | aim (mm) | yaw (°) | obliquity (°) | outcome | left (m/s) | steps "
                     "| ended (µs) | breaks: tension / shear / combined | breaks by layer | energy balance (%) | core-h |")
        lines.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for s in sorted(c.shots, key=lambda s: s["id"]):
            aim = s.get("aim_offset_m")
            aim = f"{1e3 * (aim[0] ** 2 + aim[1] ** 2) ** 0.5:.2f}" if aim is not None else "–"
            yaw = f"{s['yaw_deg']:+.2f}" if "yaw_deg" in s else "–"
            obliquity = f"{s['obliquity_deg']:+.2f}" if "obliquity_deg" in s else "–"
            ended, modes, layers = trace_end_words(c.name, s["id"])
            # |E − E0| / E0 at the shot's end (theory I11b); records written before it was kept have none
            balance = s.get("energy_balance_error")
            balance = f"{100.0 * balance:.2f}" if balance is not None else "–"
            lines.append(f"| {s['id']} | {s['velocity_m_s']:.2f} | {aim} | {yaw} | {obliquity} | {outcome_words(s)} "
                         f"| {s['residual_velocity_m_s']:.1f} | {s['steps']} | {ended} | {modes} | {layers} "
                         f"| {balance} | {s['wall_s'] * s['ranks'] / 3600.0:.2f} |")
        lines.append("")
    pools = [e for e in entries if e.get("pooled_from")]
    if pools:
        lines.append("## Pooled series")
        lines.append("")
        lines.append("Series of one target, their shots together (`dea-mpi fit`, docs/theory.md V10):")
        lines.append("")
        for e in pools:
            v50 = (f"V50 {e['v50_m_s']:.1f} m/s ({e['v50_low_m_s']:.1f}–{e['v50_high_m_s']:.1f}): {e['method']}"
                   if e["v50_m_s"] is not None else e["method"])
            names = [f"`{name}`" for name in e["pooled_from"]]
            lines.append(f"- {', '.join(names[:-1])} and {names[-1]}, {e['shots']} shots: {v50}.")
        lines.append("")
    if waiting:
        lines.append("## Not fired yet")
        lines.append("")
        lines.append(", ".join(f"`{name}`" for name in waiting) + ".")
        lines.append("")
    return "\n".join(lines)


# What a shot's trace keeps of its run directory's history.csv (docs/output.md): the
# projectile's course and the breaks, every column whose name starts with one of these.
TRACE_COLUMN_STARTS = ("time_s", "projectile_position_z_m", "projectile_velocity_", "projectile_angular_velocity_",
                       "projectile_force_z_N", "energy_total_J", "broken_", "back_face_at_axis_m")
# at most this many rows, evenly spread over the history, its first and last kept: a yarn shot
# of 800 us writes thousands, and a trace is for reading a shot's course back, not for restarts
TRACE_ROWS = 400


def trace_path(name, shot_id):
    return os.path.join(RESULTS, name, "shots", f"{shot_id}.trace.csv")


def write_trace(name, shot_id):
    """Writes `shots/<id>.trace.csv` beside the shot's record from its run directory's
    history.csv, so that what the docs say of a shot's course (its speed at a given time, when
    it turned, how many elements broke in which layer) can be read from a checkout after the
    run directory, which stays on the machine that fired it, is gone. The columns of
    TRACE_COLUMN_STARTS, as history.csv wrote them (the same digits), thinned to TRACE_ROWS
    rows. Returns the path, or None when the run directory holds no history (a shot fired on
    another machine)."""
    history = os.path.join(RESULTS, name, "shots", shot_id, "history.csv")
    try:
        with open(history, newline="") as f:
            rows = list(csv.reader(f))
    except OSError:
        return None
    if len(rows) < 2:
        return None
    header, body = rows[0], rows[1:]
    for line, row in enumerate(body, start=2):
        if len(row) != len(header):
            sys.exit(f"{history}: line {line} has {len(row)} fields where the header has {len(header)}; "
                     "no trace written (is the shot still running?)")
    kept = [k for k, column in enumerate(header) if column.startswith(TRACE_COLUMN_STARTS)]
    if len(body) > TRACE_ROWS:
        last = len(body) - 1
        body = [body[i] for i in sorted({round(j * last / (TRACE_ROWS - 1)) for j in range(TRACE_ROWS)})]
    path = trace_path(name, shot_id)
    with open(path + ".partial", "w", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        for row in [header] + body:
            writer.writerow([row[k] for k in kept])
    os.replace(path + ".partial", path)
    return path


def trace_end_words(name, shot_id):
    """What a shot's trace says of its end, as shots.md prints it: the simulated time of its
    last row in µs, the broken elements by failure mode (tension / shear / combined, theory
    I10) and by layer, struck face first. Each "–" where the shot has no trace (those fired
    before traces were kept) or the trace lacks those columns."""
    try:
        with open(trace_path(name, shot_id), newline="") as f:
            rows = list(csv.reader(f))
    except OSError:
        return "–", "–", "–"
    if len(rows) < 2:
        return "–", "–", "–"
    last = dict(zip(rows[0], rows[-1]))
    ended = f"{float(last['time_s']) * 1e6:.1f}" if "time_s" in last else "–"
    modes = ("–" if any(f"broken_{m}" not in last for m in ("tension", "shear", "combined"))
             else " / ".join(last[f"broken_{m}"] for m in ("tension", "shear", "combined")))
    layers = " / ".join(last[column] for column in layer_columns(last)) or "–"
    return ended, modes, layers


def layer_columns(trace):
    """The trace's `broken_layer_<k>` columns in layer order (k as a number: 2 before 10)."""
    columns = [c for c in trace if c.startswith("broken_layer_")]
    return sorted(columns, key=lambda c: int(c.rsplit("_", 1)[1]))


def write_missing_traces(campaigns):
    """The traces of the shots on record that have none and whose run directory is still on
    this machine; the paths written."""
    written = []
    for c in campaigns:
        for s in c.shots:
            if not os.path.exists(trace_path(c.name, s["id"])):
                path = write_trace(c.name, s["id"])
                if path is not None:
                    written.append(path)
    return written


def commit(c, new_ids):
    paths = [os.path.join(RESULTS, c.name, "shots", f"{i}.json") for i in new_ids]
    paths += [trace_path(c.name, i) for i in new_ids]
    paths += [os.path.join(RESULTS, c.name, f) for f in ("v50.json", "provenance.json")]
    paths += [os.path.join(RESULTS, "summary.json"), os.path.join(RESULTS, "shots.md")]
    # a campaign whose whole shots price the cost model: its file follows the record in the
    # same commit, or the test command's `whole-shots.py --check` refuses the tree
    refreshed = refresh_whole_shots(c.name)
    if refreshed is not None:
        paths.append(refreshed)
    paths = [p for p in paths if os.path.exists(p)]
    shots = {s["id"]: s for s in c.shots}
    words = []
    for i in new_ids:
        s = shots[i]
        outcome = f"perforated, {s['residual_velocity_m_s']:.1f} m/s left" if s["perforated"] else f"stopped ({s['stopped_by']})"
        words.append(f"{s['velocity_m_s']:.1f} m/s {outcome}")
    body = "\n".join([f"campaign {c.name}"] + [f"{i}: {json.dumps(shots[i])}" for i in new_ids])
    git_commit_paths(paths, commit_subject(c.name, words), body)


def refresh_whole_shots(name):
    """scripts/whole-shots.py's `refresh` of `name` against the records under RESULTS: the
    path of docs/benchmarks/whole-shots.json when it was rewritten, else None."""
    spec = importlib.util.spec_from_file_location("whole_shots", os.path.join(ROOT, "scripts", "whole-shots.py"))
    whole_shots = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(whole_shots)
    whole_shots.validation.RESULTS = RESULTS
    return whole_shots.refresh(name)


def commit_subject(name, words):
    """The subject of a record's commit, at most 72 characters: the campaign and each shot's
    outcome, else the campaign and the count, else the count alone (the body names the
    campaign)."""
    for subject in (f"validation: {name} " + "; ".join(words), f"validation: {name}, {len(words)} shot(s)",
                    f"validation: {len(words)} shot(s) of a campaign named in the body"):
        if len(subject) <= 72:
            return subject
    return subject


def git_commit_paths(paths, subject, body):
    """Commits only `paths` (whatever else is staged stays staged), retrying while another
    git command holds the index."""
    for attempt in range(10):
        added = subprocess.run(["git", "-C", ROOT, "add", "--", *paths])
        if added.returncode == 0:
            unchanged = subprocess.run(["git", "-C", ROOT, "diff", "--quiet", "HEAD", "--", *paths]).returncode == 0
            if unchanged:
                # another run (a second validation.py) committed these very files already
                return
            done = subprocess.run(["git", "-C", ROOT, "commit", "-q", "-m", subject, "-m", body, "--", *paths])
            if done.returncode == 0:
                return
        time.sleep(2.0 * (attempt + 1))
    sys.exit(f"could not commit {paths}")


def commit_pending(campaigns, chosen):
    """Commits the shot records of the campaigns this run works on (`chosen`) left
    uncommitted by an earlier run without --commit; another validation.py may be running the
    others and will commit its own."""
    for c in chosen:
        listed = subprocess.run(["git", "-C", ROOT, "ls-files", "--others", "--modified", "--exclude-standard", "--",
                                 os.path.join(RESULTS, c.name, "shots")], capture_output=True, text=True).stdout.split()
        # a record withdrawn to take its shot on (`take_on_held`) is listed too, as deleted:
        # its shot is not finished, and the commit of its outcome will carry it
        new = sorted(os.path.basename(p)[:-5] for p in listed
                     if p.endswith(".json") and os.path.exists(os.path.join(ROOT, p)))
        if new:
            for shot_id in new:
                if not os.path.exists(trace_path(c.name, shot_id)):
                    write_trace(c.name, shot_id)
            write_summary(campaigns)
            commit(c, new)


def shot_command(args, c):
    """The `mpirun` that fires `c`'s next shot. Unbound (`--bind-to none`): Open MPI binds
    a job of one or two ranks to cores counted from core 0, so two campaigns run side by side,
    each its own `mpirun`, would share core 0 while core 1 idles (docs/performance.md, "jobs
    side by side run unbound")."""
    command = ["mpirun", "--bind-to", "none", "-np", str(args.ranks)]
    if args.ranks > os.cpu_count():
        command.append("--oversubscribe")
    return command + [binary(args), "v50", c.path, "--out", os.path.join(RESULTS, c.name), "--shots-per-group", "1"]


def run_state(name, shot_id):
    """How far a shot's run directory (not committed: on the machine that fired it) got: its
    simulated time [s] from summary.json, and whether a checkpoint is there to go on from;
    (None, False) without one."""
    directory = os.path.join(RESULTS, name, "shots", shot_id)
    try:
        with open(os.path.join(directory, "summary.json")) as f:
            time_s = float(json.load(f)["simulated_time_s"])
    except (OSError, ValueError, KeyError, TypeError):
        return None, False
    return time_s, resumable(directory)


def held_to_take_on(c, state=run_state):
    """The shots of `c` undecided at an end time shorter than the campaign's now, whose run
    directory keeps a checkpoint to go on from (dea-mpi continues a checkpoint under a
    campaign's later end time, docs/theory.md V1): [(id, simulated time [s])]. Only the last
    shot of its replicate: the speeds after a shot rest on its outcome, so a decided shot with
    later ones on record is left as it is (it would no longer be the campaign's)."""
    end = float(c.case["run"]["end_time_s"])
    last = {}
    for s in c.shots:
        replicate = s.get("replicate", 0)
        last[replicate] = max(last.get(replicate, -1), s.get("index", 0))
    chosen = []
    for s in c.shots:
        if s["stopped_by"] != "end_time_s" or s.get("index", 0) != last[s.get("replicate", 0)]:
            continue
        time_s, resumable = state(c.name, s["id"])
        if time_s is not None and resumable and time_s < end * (1.0 - 1e-9):
            chosen.append((s["id"], time_s))
    return chosen


def take_on_held(c):
    """Withdraws the records of `held_to_take_on(c)`, so that the campaign's next run
    continues those shots to its end time; the shot's new record replaces the old in the
    commit of its outcome (until then a checkout keeps the old)."""
    end = float(c.case["run"]["end_time_s"])
    held = held_to_take_on(c)
    for shot_id, time_s in held:
        # its trace (if any) stays, as the old record does in a checkout, until the shot's
        # outcome writes the new one and commits both
        os.remove(os.path.join(RESULTS, c.name, "shots", f"{shot_id}.json"))
        print(f"{c.name}: shot {shot_id} was undecided at its end, {1e6 * time_s:.1f} us, and the campaign now "
              f"ends at {1e6 * end:.1f} us: its record is withdrawn and the shot goes on from its checkpoint",
              flush=True)
    if held:
        c.refresh()


class StopForwarder:
    """While a run lasts, SIGTERM and SIGUSR1 to this script set `asked` and reach the running
    `mpirun` as SIGUSR1, which Open MPI forwards to its ranks; SIGTERM would make it kill them
    (the module's doc)."""

    SIGNALS = (signal.SIGTERM, signal.SIGUSR1)

    def __init__(self):
        self.asked = False
        self.process = None

    def __enter__(self):
        self.previous = {s: signal.signal(s, self.forward) for s in self.SIGNALS}
        return self

    def __exit__(self, *_):
        for s, handler in self.previous.items():
            signal.signal(s, handler)

    def forward(self, signum, _frame):
        self.asked = True
        print(f"signal {signal.Signals(signum).name}: the shot checkpoints and the run stops", file=sys.stderr,
              flush=True)
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGUSR1)

    def call(self, command):
        """Run `command` to its end (a signal handled meanwhile does not end the wait, PEP 475);
        its exit code."""
        self.process = subprocess.Popen(command)
        try:
            return self.process.wait()
        finally:
            self.process = None


def run(args, campaigns):
    with StopForwarder() as stop:
        return run_until_stopped(args, campaigns, stop)


def run_until_stopped(args, campaigns, stop):
    fired = 0
    for c in campaigns:
        take_on_held(c)
        while not c.complete:
            if args.max_shots is not None and fired >= args.max_shots:
                print(f"stopped after --max-shots {args.max_shots}")
                return 0
            if stop.asked:
                print(f"{c.name}: stopped by a signal before its next shot; run again to go on", file=sys.stderr)
                return 75
            before = {s["id"] for s in c.shots}
            command = shot_command(args, c)
            print("+", " ".join(command), flush=True)
            code = stop.call(command)
            c.refresh()
            new = sorted({s["id"] for s in c.shots} - before)
            for shot_id in new:
                write_trace(c.name, shot_id)
            if new:
                write_summary(load_all(args))
                if args.commit:
                    commit(c, new)
                fired += len(new)
            if code != 0:
                print(f"{c.name}: dea-mpi v50 exited {code}; the shots on record are kept", file=sys.stderr)
                return code
            if not new and not c.complete:
                with open(c.path) as f:
                    edited = json.load(f) != c.spec
                if edited:
                    # `dea-mpi v50` read the file as it is now; this script planned by the file
                    # it loaded (a design cut while a shot ran, say)
                    sys.exit(f"{c.name}: {c.path} changed while this script ran, and dea-mpi v50 "
                             f"fired no shot by it; run again to plan by the file as it is now")
                sys.exit(f"{c.name}: dea-mpi v50 fired no shot and the design is not complete")
    if args.only:
        left = [c.name for c in load_all(args) if not c.complete and args.only not in c.name]
        print(f"every validation campaign whose name contains {args.only!r} is complete"
              + (f"; {len(left)} other(s) still to run (validation.py status)" if left else ""))
    else:
        print("every validation campaign is complete")
    return 0


def load_all(args):
    saved, args.only = args.only, None
    try:
        return load(args)
    finally:
        args.only = saved


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("action", choices=["status", "run", "summary"])
    parser.add_argument("--ranks", type=int, default=2, help="ranks per shot (mpirun -np)")
    parser.add_argument("--max-shots", type=int, help="stop after this many new shots")
    parser.add_argument("--only", help="only campaigns whose name contains this text")
    parser.add_argument("--commit", action="store_true", help="commit each finished shot's record")
    parser.add_argument("--binary", help="the dea-mpi to run (default: target/release/dea-mpi)")
    args = parser.parse_args()
    campaigns = load(args)
    if args.action == "status":
        status(campaigns)
        return 0
    if args.action == "summary":
        everything = load_all(args)
        for path in write_missing_traces(everything):
            print(path)
        print(write_summary(everything))
        return 0
    status(campaigns)
    if args.commit:
        commit_pending(load_all(args), campaigns)
    return run(args, campaigns)


if __name__ == "__main__":
    sys.exit(main())
