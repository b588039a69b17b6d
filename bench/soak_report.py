#!/usr/bin/env python3
"""Figures of a soak run (bench/soak.sh), from what it left in OUT_DIR:

  soak.csv          every 10 s: t_s, process, rss_kb, cpu_pct, missed_deadlines
  base.out          the basestation's JSON answers, among them `health R` every minute
  health_times.txt  the soak's clock (s) at each round of `health R`

usage: soak_report.py OUT_DIR BASELINE_S

RSS growth compares windows, not single samples: the mean RSS over the WINDOW_S after BASELINE_S against the
mean over the last WINDOW_S, each three patrol cycles (soak.sh sends a goal every 40 s: a cycle is 80 s). Since
blocks of 1 MB and more are mapped apart and handed back when freed (ReturnLargeBlocksWhenFreed), a robot's RSS
follows what it holds: it swings by tens of MB with the patrol (a navigation map update copies the grids it
changes; the planner's workspace for a goal), so one sample against another measures the phase of the patrol,
not a leak. A leak lifts the floor (the least sample) and the peak of a window alike, whatever the phase: the
bound applies to the larger of the two growths; the mean (phase-dependent) is printed too. Writes OUT_DIR/health.csv (the
robots' own view: their maps' memory and RSS) and prints FIGURE lines.
"""
import csv
import json
import statistics
import sys

WINDOW_S = 240


def windows(rows, baseline_s):
    """(baseline rows, end rows) of time-sorted rows with a t_s key."""
    last_t = rows[-1]["t_s"]
    base = [r for r in rows if baseline_s <= r["t_s"] < baseline_s + WINDOW_S] or rows[:1]
    end = [r for r in rows if r["t_s"] > last_t - WINDOW_S] or rows[-1:]
    return base, end


def growth(a, b):
    return 100.0 * (b - a) / max(1, a)


def main():
    out_dir, baseline_s = sys.argv[1], int(sys.argv[2])
    by = {}
    for r in csv.DictReader(open(f"{out_dir}/soak.csv")):
        by.setdefault(r["process"], []).append(
            {"t_s": int(r["t_s"]), "rss_kb": int(r["rss_kb"]), "cpu": float(r["cpu_pct"]),
             "missed": int(r["missed_deadlines"])})
    worst = None
    mb = lambda kb: f"{kb / 1024:.1f}"
    for name, rows in sorted(by.items()):
        base, end = windows(rows, baseline_s)
        b_med, e_med = statistics.mean(r["rss_kb"] for r in base), statistics.mean(r["rss_kb"] for r in end)
        b_min, e_min = min(r["rss_kb"] for r in base), min(r["rss_kb"] for r in end)
        b_max, e_max = max(r["rss_kb"] for r in base), max(r["rss_kb"] for r in end)
        g = max(growth(b_min, e_min), growth(b_max, e_max))
        worst = g if worst is None else max(worst, g)
        cpu = sum(r["cpu"] for r in rows) / len(rows)
        peak = max(r["rss_kb"] for r in rows)
        print(f"FIGURE soak {name}: RSS over {base[0]['t_s']}-{base[-1]['t_s']} s -> {end[0]['t_s']}-"
              f"{end[-1]['t_s']} s: floor {mb(b_min)} -> {mb(e_min)} MB ({growth(b_min, e_min):+.2f} %), peak "
              f"{mb(b_max)} -> {mb(e_max)} MB ({growth(b_max, e_max):+.2f} %), mean {mb(b_med)} -> {mb(e_med)} MB "
              f"({growth(b_med, e_med):+.2f} %); run peak {mb(peak)} MB; mean CPU {cpu:.1f} % of one core; missed "
              f"control deadlines {rows[-1]['missed']}")
    print(f"FIGURE soak worst RSS growth after the baseline (the larger of floor and peak, {WINDOW_S} s windows): "
          f"{worst:+.2f} % (bound: 5 %)")

    # The robots' own view: health answers in the order the rounds were asked.
    times = [int(t) for t in open(f"{out_dir}/health_times.txt").read().split()]
    answers = {}
    for line in open(f"{out_dir}/base.out"):
        try:
            j = json.loads(line)
        except ValueError:
            continue
        if j.get("command") == "health":
            answers.setdefault(j.get("robot"), []).append(j)
    worst = None
    with open(f"{out_dir}/health.csv", "w") as out:
        out.write("t_s,robot,perception_maps_kb,planning_map_kb,rss_kb\n")
        for robot, js in sorted(answers.items()):
            rows = []
            for t, j in zip(times, js):
                if not j.get("ok"):
                    continue
                mem = {c["name"]: c["memory_bytes"] // 1024 for c in j["components"]}
                row = {"t_s": t, "perception": mem.get("perception", 0), "planning": mem.get("planning", 0),
                       "rss_kb": j["rss_bytes"] // 1024}
                rows.append(row)
                out.write(f"{t},{robot},{row['perception']},{row['planning']},{row['rss_kb']}\n")
            if not rows:
                continue
            base, end = windows(rows, baseline_s)
            maps = lambda rs: statistics.mean(r["perception"] + r["planning"] for r in rs)
            net = lambda rs: statistics.mean(r["rss_kb"] - r["perception"] - r["planning"] for r in rs)
            g = 100.0 * (net(end) - net(base)) / max(1, statistics.mean(r["rss_kb"] for r in base))
            worst = g if worst is None else max(worst, g)
            print(f"FIGURE soak {robot} (its health, means): maps {mb(maps(base))} -> {mb(maps(end))} MB, RSS less "
                  f"its maps {mb(net(base))} -> {mb(net(end))} MB: growth net of its maps {g:+.2f} % of its RSS")
    if worst is not None:
        # Four answers a window, a minute apart: the patrol's phase moves this figure by several per cent; the
        # bound is judged on the 10 s samples above.
        print(f"FIGURE soak worst RSS growth net of the maps after the baseline: {worst:+.2f} % (health answers "
              "a minute apart: phase-dependent, not the bound's figure)")


if __name__ == "__main__":
    main()
