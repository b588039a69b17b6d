#!/usr/bin/env bash
# Plots exploration coverage against time from cairn_bench_explore --csv (rows "robots,t_s,coverage"), one line
# per team size, into a PNG (gnuplot, Debian's gnuplot-nox, installed by ./cairn's setup step).
#
#   tools/plot_explore_coverage.sh COVERAGE.csv OUT.png ["title"]
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: $0 COVERAGE.csv OUT.png [title]" >&2
  exit 2
fi
csv="$1"
png="$2"
title="${3:-Exploration coverage against time}"
command -v gnuplot > /dev/null || { echo "$0: gnuplot not found (apt-get install gnuplot-nox)" >&2; exit 1; }
[[ -r "$csv" ]] || { echo "$0: cannot read '$csv'" >&2; exit 1; }
head -1 "$csv" | grep -qx 'robots,t_s,coverage' || { echo "$0: '$csv' does not start with the header robots,t_s,coverage" >&2; exit 1; }
teams=$(tail -n +2 "$csv" | cut -d, -f1 | sort -un | tr '\n' ' ')
[[ -n "$teams" ]] || { echo "$0: '$csv' has no rows" >&2; exit 1; }
plot=""
for n in $teams; do
  label="$n robot"; [[ "$n" != 1 ]] && label="$n robots"
  plot+="${plot:+, }'$csv' using (\$1 == $n ? \$2 / 60 : 1/0):(\$3 * 100) with lines lw 2 title '$label'"
done
gnuplot <<GP
set terminal pngcairo size 900,540 font "sans,11" noenhanced
set output "$png"
set datafile separator ","
set key bottom right
set grid
set title "$title"
set xlabel "simulated time, min"
set ylabel "reachable floor known, %"
set yrange [0:100]
set arrow from graph 0, first 90 to graph 1, first 90 nohead dt 2 lc rgb "gray40"
plot $plot
GP
echo "wrote $png"
