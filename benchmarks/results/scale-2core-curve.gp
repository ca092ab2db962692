# Per-truck cost curve of the marginal core (scale_benchmark): mean wall ms per truck over (n/2, n].
#   gnuplot benchmarks/results/scale-2core-curve.gp   (run from the repository root)
set terminal pngcairo size 900,600 font ",11"
set output "docs/scale_curve.png"
set datafile separator ","
set logscale xy
set xlabel "trucks absorbed n"
set ylabel "mean wall ms per truck over (n/2, n]"
set title "MarginalSmc, 1,024 particles, 2 threads (Table 1 fleet, AS1, {/Symbol s}_{IF} = 0.02)"
set grid xtics ytics mxtics mytics
set key top left
set format x "10^{%L}"
stats "benchmarks/results/scale-2core-curve.csv" skip 1 using ($1 == 2000 ? $2 : 1/0) nooutput name "E"
set key top right
plot "benchmarks/results/scale-2core-curve.csv" skip 1 using 1:2 with linespoints pt 7 ps 0.6 lw 2 title "marginal core (scale\\_benchmark)", \
     1000.0/30 with lines dt 2 lc rgb "red" title "30 trucks/s (33.3 ms)", \
     2*E_max with lines dt 3 lc rgb "dark-green" title "2 x (1,000, 2,000] window"
