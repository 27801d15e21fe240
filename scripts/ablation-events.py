#!/usr/bin/env python3
"""Sound by sound, what one mechanism of the spectral matcher changes: each folder's sets
scored with the mechanism on and off (an `ablation` build, `ONOMATO_ABLATE`, as
scripts/ablation.py), then every annotated impulse found one way and not the other, and
every event one way that matches no annotation, counted per folder.

    python3 scripts/ablation-events.py /tmp/onomato-ablation SWITCH FOLDER... [--takes FOLDER...]

FOLDERs after `--takes` are enrolled from their `more_takes/` too (scripts/with-more-takes.sh,
as scripts/robustness.sh scores them). An impulse is found when an event of its label
lies within 50 ms of it, each event used once, nearest first (the dev sets' rule).
Needs only Python's standard library.
"""

import csv
import glob
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ablation import HERE, RUN, require_ablation_build  # noqa: E402

WITH_TAKES = os.path.join(HERE, "with-more-takes.sh")
TOLERANCE = 0.05


def run(binary, folder, switch, tag, takes):
    env = dict(os.environ, TAG=tag, SUMMARY=os.path.join(folder, f"summary.{tag}.json"))
    env.pop("ONOMATO_ABLATE", None)
    if switch:
        env["ONOMATO_ABLATE"] = switch
    command = ["bash", RUN, binary, folder]
    if takes:
        env["ONOMATO"] = binary
        command = ["bash", RUN, WITH_TAKES, folder]
    done = subprocess.run(command, env=env, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"ablation-events.py: run.sh failed on {folder}:\n{done.stderr[-2000:]}")


def events(path):
    with open(path) as f:
        data = json.load(f)
    listed = data["events"] if isinstance(data, dict) else data
    return [(e["time"], e["pattern"]) for e in listed if e.get("kind", "impulse") == "impulse"]


def matched(truth, detected):
    """The indices of truth and of detected that match, closest pairs first."""
    pairs = sorted(
        (abs(t - d), i, j)
        for i, (t, tl) in enumerate(truth)
        for j, (d, dl) in enumerate(detected)
        if tl == dl and abs(t - d) <= TOLERANCE
    )
    used_t, used_d = set(), set()
    for _, i, j in pairs:
        if i not in used_t and j not in used_d:
            used_t.add(i)
            used_d.add(j)
    return used_t, used_d


def compare(folder):
    found_on = found_off = false_on = false_off = 0
    moved = []
    for seq in sorted(glob.glob(os.path.join(folder, "*", "seq_*.csv"))):
        base = seq[:-4]
        with open(os.path.join(os.path.dirname(seq), "set.json")) as f:
            kinds = json.load(f)["kinds"]
        with open(seq) as f:
            truth = [(float(r["onset_s"]), r["label"]) for r in csv.DictReader(f)
                     if kinds.get(r["label"]) == "impulse"]
        on = events(f"{base}.events-on.json")
        off = events(f"{base}.events-off.json")
        t_on, d_on = matched(truth, on)
        t_off, d_off = matched(truth, off)
        found_on += len(t_on - t_off)
        found_off += len(t_off - t_on)
        false_on += len(on) - len(d_on)
        false_off += len(off) - len(d_off)
        for i in sorted(t_on ^ t_off):
            where = os.path.relpath(base, folder)
            moved.append(f"{where} {truth[i][1]} {truth[i][0]:.3f} s "
                         f"({'on' if i in t_on else 'off'})")
    return found_on, found_off, false_on, false_off, moved


def main(argv):
    if len(argv) < 4:
        sys.exit(__doc__)
    binary, switch = os.path.abspath(argv[1]), argv[2]
    folders, with_takes = [], False
    for a in argv[3:]:
        if a == "--takes":
            with_takes = True
            continue
        folders.append((os.path.abspath(a), with_takes))
    for folder, _ in folders:
        if not os.path.isdir(folder):
            sys.exit(f"ablation-events.py: no folder {folder}")
    require_ablation_build(binary, "ablation-events.py")
    print(f"| folder | impulses found only with `{switch}` | only without | "
          "unmatched events with | without |")
    print("|---|---|---|---|---|")
    totals = [0, 0, 0, 0]
    details = []
    for folder, with_takes in folders:
        run(binary, folder, None, "events-on", with_takes)
        run(binary, folder, switch, "events-off", with_takes)
        *counts, moved = compare(folder)
        totals = [a + b for a, b in zip(totals, counts)]
        name = os.path.basename(folder) + (" (takes)" if with_takes else "")
        print(f"| {name} | " + " | ".join(str(c) for c in counts) + " |")
        details += [f"{name}: {m}" for m in moved]
    print("| all | " + " | ".join(str(c) for c in totals) + " |")
    print()
    for d in details:
        print(f"- {d}")


if __name__ == "__main__":
    main(sys.argv)
