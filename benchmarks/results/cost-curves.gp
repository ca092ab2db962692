# Per-truck cost against the number of trucks n, log-log (issue 14, item 8), for the README:
#   marginal core   scale_benchmark --curve      scale-2core-curve.csv   mean wall ms per truck over (n/2, n]
#   latent core     cost_curves_benchmark         cost-latent-curve.csv   the same windows, until its time budget
#   batch MCMC      cost_curves_benchmark --ratio cost-mcmc-curve.csv     time to ESS 400 at N trucks: per truck
#                   (an offline fit of N trucks, amortised) and whole (an online fit re-running it per truck)
#   gnuplot benchmarks/results/cost-curves.gp   (from the repository root)
set terminal pngcairo size 960,640 font ",11"
set output "docs/scale_curve.png"
set datafile separator ","
set logscale xy
set xlabel "trucks n"
set ylabel "wall ms per truck"
set title "Cost per truck, 1,024 particles / 2 threads (Table 1 fleet, AS1, {/Symbol s}_{IF} = 0.02)"
set grid xtics ytics mxtics mytics
set format x "10^{%L}"
set format y "10^{%L}"
set key top left box opaque
plot "benchmarks/results/scale-2core-curve.csv" skip 1 using 1:2 with linespoints pt 7 ps 0.5 lw 2 lc rgb "#1f77b4" \
       title "marginal core (default): mean over (n/2, n]", \
     "benchmarks/results/cost-latent-curve.csv" skip 2 using 1:2 with linespoints pt 5 ps 0.6 lw 2 lc rgb "#d62728" \
       title "latent core (0.1): mean over (n/2, n], until 700 s", \
     "benchmarks/results/cost-mcmc-curve.csv" skip 1 using 1:3 with linespoints pt 9 ps 1.0 lw 2 lc rgb "#2ca02c" \
       title "batch MCMC to ESS 400, offline: time / N", \
     "benchmarks/results/cost-mcmc-curve.csv" skip 1 using 1:4 with linespoints pt 8 ps 1.0 lw 2 dt 2 lc rgb "#2ca02c" \
       title "batch MCMC to ESS 400, online: one rerun per truck", \
     1000.0/30 with lines dt 3 lc rgb "black" title "30 trucks/s"
