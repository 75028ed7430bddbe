# Plots the samples of stress.soak (tst_soak.cpp writes them to $IRIS_TEST_OUT/soak.csv, or to
# $IRIS_SOAK_CSV) as a PNG: resident memory and the three RAM caches over time, and the open
# file descriptors below.
#
#   gnuplot -e "csv='build/dev/testdata/soak.csv'; out='docs/reliability/soak.png'" tests/stress/soak-plot.gp
#
# Optional: warmup (seconds; the test's is 20 % of the run, at least 10 s) draws the line after
# which the test requires flat memory and descriptors; title names the run.
if (!exists("csv")) csv = 'soak.csv'
if (!exists("out")) out = 'soak.png'
if (!exists("title")) title = 'stress.soak'

set datafile separator ','
set terminal pngcairo size 1000,700 font 'DejaVu Sans,10'
set output out
set multiplot layout 2,1 title title

set key outside right top
set grid
set xlabel 'time (s)'
set lmargin 10
set rmargin 28
if (exists("warmup")) set arrow 1 from warmup, graph 0 to warmup, graph 1 nohead dt 2 lc rgb '#888888'
if (exists("warmup")) set label 1 'warm-up ends' at warmup, graph 0.95 offset 0.5,0 tc rgb '#888888'

# Columns: 1 t_s, 2 rss_mib, 3 fds, then per engine i (0..2) five columns from 4 + 5i:
# cache, budget, atlas, active slots, frames; last: validation messages.
set ylabel 'MiB'
set yrange [0:*]
plot csv using 1:2 skip 1 with lines lw 2 lc rgb '#1f4e9a' title 'process RSS', \
     csv using 1:($4 + $9 + $14) skip 1 with lines lw 1.5 lc rgb '#d1700b' title 'RAM caches, 3 engines', \
     csv using 1:($5 + $10 + $15) skip 1 with lines dt 2 lc rgb '#d1700b' title 'RAM budgets, 3 engines', \
     csv using 1:($6 + $11 + $16) skip 1 with lines dt 3 lc rgb '#2c8a3c' title 'atlases (fixed)'

set ylabel 'open descriptors'
set yrange [0:*]
plot csv using 1:3 skip 1 with steps lw 2 lc rgb '#7a1f9a' title 'process fds'

unset multiplot
