#!/usr/bin/env python3
"""What each mechanism of the spectral matcher contributes: every protocol scored with it
turned off alone.

A build with the `ablation` feature reads `ONOMATO_ABLATE` (names separated by commas)
and turns those mechanisms off (`src/detect/ablation.rs`; with the variable unset it
gives the same events as any other build). This runs ../shared/devsets/run.sh with each
name in turn (and with none) on the development sets and on six folders of
scripts/robustness.sh (the two unheard voice folders, the beats enrolled from other
loops, the real sets enrolled from their second take, the 0.47 s room and pink noise),
and prints two Markdown tables: one row per switch, and the sets each moved.

    cargo build --release --features ablation && cp target/release/onomato /tmp/onomato-ablation
    bash ../shared/devsets/build.sh /tmp/devsets
    bash scripts/robustness.sh target/release/onomato /tmp/devsets /tmp/robustness \\
        voices voices-more other-loops take2 room-0.47s pink
    python3 scripts/ablation.py /tmp/onomato-ablation /tmp/devsets /tmp/robustness [--reuse] [NAME ...]

Summaries go to WORK_DIR/ablation/ (one JSON per switch and folder); with `--reuse`
those already there are read instead of run again (the tables printed anew). About 100 s
a switch on 2 cores. Needs only Python's standard library.
"""

import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
RUN = os.path.join(HERE, "..", "..", "shared", "devsets", "run.sh")
# The names src/detect/ablation.rs knows, in its order.
NAMES = [
    "quiet_before", "over_fired", "over_tail", "speech_guard", "cover_stopped",
    "continuation", "soft_start_attack", "repeated", "background", "second_look",
    "min_strength", "pair_waits", "between_two", "copies", "tracking", "dated_back",
    "second_placement", "same_onset",
]
# (column, folder under WORK_DIR); the dev sets are the first.
FOLDERS = [
    ("voices", "voices"),
    ("`--more`", "voices-more"),
    ("other loops", "other-loops"),
    ("take 2", "take2"),
    ("room 0.47 s", "room25"),
    ("pink", "pink"),
]
MOVED = 0.02
# The largest moves named in the second table.
SHOWN = 3


def score(binary, folder, switch, out_dir, reuse):
    name = os.path.basename(folder.rstrip("/"))
    summary = os.path.join(out_dir, f"{switch}.{name}.json")
    if reuse and os.path.exists(summary):
        with open(summary) as f:
            return json.load(f)
    env = dict(os.environ, TAG=f"ablation-{switch}", SUMMARY=summary)
    if switch != "none":
        env["ONOMATO_ABLATE"] = switch
    else:
        env.pop("ONOMATO_ABLATE", None)
    done = subprocess.run(["bash", RUN, binary, folder], env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0 or not os.path.exists(summary):
        sys.exit(f"ablation.py: run.sh failed on {folder} with {switch} off:\n{done.stderr[-2000:]}")
    with open(summary) as f:
        return json.load(f)


def require_ablation_build(binary, script):
    """Exits unless `binary` reads ONOMATO_ABLATE (a build without the `ablation`
    feature ignores it, and every switch would score as nothing turned off)."""
    examples = os.path.join(HERE, "..", "examples")
    probe = subprocess.run(
        [binary, "analyze", os.path.join(examples, "beat.wav"),
         "--pattern", "tick=" + os.path.join(examples, "patterns", "tick.wav")],
        env=dict(os.environ, ONOMATO_ABLATE="no-such-mechanism"),
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if probe.returncode == 0 or "ONOMATO_ABLATE" not in probe.stderr:
        sys.exit(f"{script}: {binary} ignores ONOMATO_ABLATE; build it with "
                 "`cargo build --release --features ablation`")


def positive(summary):
    return {k: v["f1"] for k, v in summary["sets"].items() if not v["negative"]}


def speech(summary):
    return summary["false_per_min_negative"]


def row(switch, dev, others):
    sets = dev["sets"]
    f1 = positive(dev)
    worst = min(f1, key=f1.get)
    fam = dev["mean_f1_by_family"]
    espeak = max((v["false_per_min"], k) for k, v in sets.items()
                 if v["negative"] and k.startswith("N_speech_espeak"))
    real = sets["N_speech_real"]["false_per_min"]
    late = sum(1 for v in sets.values()
               if not v["negative"] and (v.get("latency_ms_p95") or 0) > 30)
    cells = [
        f"{dev['mean_f1_positive']:.3f}",
        f"{f1[worst]:.3f} ({worst})",
        " / ".join(f"{fam[k]:.3f}" for k in ("D1", "D2", "D4", "D5", "D6")),
        f"{espeak[0]:.2f}",
        f"{real:.2f}",
        str(late),
    ]
    means = [dev["mean_f1_positive"]]
    for summary in others:
        means.append(summary["mean_f1_positive"])
        if summary["negative_sets"]:
            cells.append(f"{summary['mean_f1_positive']:.3f}, {speech(summary):.2f}")
        else:
            cells.append(f"{summary['mean_f1_positive']:.3f}")
    cells.append(f"{sum(means) / len(means):.3f}")
    label = "nothing (as is)" if switch == "none" else f"`{switch}`"
    return f"| {label} | " + " | ".join(cells) + " |"


def moved(base, runs):
    """How many sets' F1 moved by MOVED or more each way, and speech sets' false events
    by half a minute's event or more, with the largest moves named."""
    up, down, louder, quieter = [], [], [], []
    for where, b, r in zip(["dev"] + [c for c, _ in FOLDERS], base, runs):
        for name, v in r["sets"].items():
            was = b["sets"][name]
            k = name if where == "dev" else f"{where}: {name}"
            if v["negative"]:
                d = v["false_per_min"] - was["false_per_min"]
                if abs(d) >= 0.5:
                    (louder if d > 0 else quieter).append(
                        (abs(d), f"{k} {was['false_per_min']:.2f} to {v['false_per_min']:.2f}"))
            elif abs(v["f1"] - was["f1"]) >= MOVED:
                (up if v["f1"] > was["f1"] else down).append(
                    (abs(v["f1"] - was["f1"]), f"{k} {was['f1']:.3f} to {v['f1']:.3f}"))

    def named(moves):
        moves.sort(reverse=True)
        shown = "; ".join(m for _, m in moves[:SHOWN])
        return f"{len(moves)}" + (f" ({shown}{'; ...' if len(moves) > SHOWN else ''})" if moves else "")

    return " | ".join(named(m) for m in (down, up, louder, quieter))


def main(argv):
    reuse = "--reuse" in argv
    argv = [a for a in argv if a != "--reuse"]
    if len(argv) < 4:
        sys.exit(__doc__)
    binary, sets, work = (os.path.abspath(a) for a in argv[1:4])
    switches = argv[4:] or NAMES
    for s in switches:
        if s not in NAMES:
            sys.exit(f"ablation.py: no switch {s!r}; expected some of {', '.join(NAMES)}")
    if not os.access(binary, os.X_OK):
        sys.exit(f"ablation.py: {binary} is not an executable file")
    require_ablation_build(binary, "ablation.py")
    folders = [sets] + [os.path.join(work, f) for _, f in FOLDERS]
    for folder in folders:
        if not os.path.isdir(folder):
            sys.exit(f"ablation.py: no folder {folder} (see the commands in this script's help)")
    out_dir = os.path.join(work, "ablation")
    os.makedirs(out_dir, exist_ok=True)
    results = {}
    for switch in ["none"] + switches:
        results[switch] = [score(binary, f, switch, out_dir, reuse) for f in folders]
        print(f"ablation.py: {switch} done", file=sys.stderr)
    head = ["turned off", "dev mean F1", "worst dev set", "D1 / D2 / D4 / D5 / D6",
            "espeak speech, worst (/min)", "real speech (/min)", "dev sets over 30 ms (p95)"]
    head += [f"{c}: F1{', speech' if results['none'][i + 1]['negative_sets'] else ''}"
             for i, (c, _) in enumerate(FOLDERS)]
    head.append("mean of the seven")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for switch, runs in results.items():
        print(row(switch, runs[0], runs[1:]))
    print()
    print(f"| turned off | sets {MOVED} or more lower | higher | speech sets 0.5 false events a minute or more higher | lower |")
    print("|---|---|---|---|---|")
    for switch in switches:
        print(f"| `{switch}` | {moved(results['none'], results[switch])} |")


if __name__ == "__main__":
    main(sys.argv)
