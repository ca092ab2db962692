# diagnose-power: written by ssrfleet reproduce; run `gnuplot diagnose-power.gp` in this folder
set datafile separator ','
if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {
  set terminal pngcairo size 1340,780 enhanced font 'sans,11' dashed
} else {
  set terminal png size 1340,780
}
set output 'diagnose-power.png'
set datafile separator ','
set multiplot layout 2,3 title 'diagnose: detection probability against effect size (Clopper-Pearson 95 % bars)'
set yrange [-0.05:1.05]
set ylabel 'detection probability'
set key bottom right
set grid
set offsets graph 0.08, graph 0.08, 0, 0
set xtics ('700000' 700000, '1000000' 1000000)
set title 'second_class' noenhanced
set xlabel 'K2' noenhanced
plot 'diagnose-power.csv' skip 1 using (strcol(1) eq 'second_class' && $4 == 50 ? $3 : NaN):7:8:9 with yerrorlines title '50 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'second_class' && $4 == 100 ? $3 : NaN):7:8:9 with yerrorlines title '100 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'second_class' && $4 == 400 ? $3 : NaN):7:8:9 with yerrorlines title '400 trucks'
set xtics ('1.02' 1.02, '1.05' 1.05)
set title 'sensor_gain' noenhanced
set xlabel 'gain' noenhanced
plot 'diagnose-power.csv' skip 1 using (strcol(1) eq 'sensor_gain' && $4 == 50 ? $3 : NaN):7:8:9 with yerrorlines title '50 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'sensor_gain' && $4 == 100 ? $3 : NaN):7:8:9 with yerrorlines title '100 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'sensor_gain' && $4 == 400 ? $3 : NaN):7:8:9 with yerrorlines title '400 trucks'
set xtics ('1.02' 1.02, '1.05' 1.05)
set title 'speed_bias' noenhanced
set xlabel 'factor' noenhanced
plot 'diagnose-power.csv' skip 1 using (strcol(1) eq 'speed_bias' && $4 == 50 ? $3 : NaN):7:8:9 with yerrorlines title '50 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'speed_bias' && $4 == 100 ? $3 : NaN):7:8:9 with yerrorlines title '100 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'speed_bias' && $4 == 400 ? $3 : NaN):7:8:9 with yerrorlines title '400 trucks'
set xtics ('1000' 1000, '2000' 2000)
set title 'tyre_damping' noenhanced
set xlabel 'c_t' noenhanced
plot 'diagnose-power.csv' skip 1 using (strcol(1) eq 'tyre_damping' && $4 == 50 ? $3 : NaN):7:8:9 with yerrorlines title '50 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'tyre_damping' && $4 == 100 ? $3 : NaN):7:8:9 with yerrorlines title '100 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'tyre_damping' && $4 == 400 ? $3 : NaN):7:8:9 with yerrorlines title '400 trucks'
set title 'clean logs: false alarms' noenhanced
set xlabel 'trucks'
set ylabel 'false-alarm rate'
set yrange [0:0.25]
set key top right
set xtics ('100' 100, '400' 400)
set arrow from graph 0, first 0.05 to graph 1, first 0.05 nohead dashtype 2
plot 'diagnose-power-false-alarms.csv' skip 1 using 1:4:5:6 with yerrorbars pt 7 title 'pooled per size, 95 % bars', NaN with lines dashtype 2 lc 'black' title 'target 5 %'
unset arrow
unset multiplot
unset output
set terminal svg size 1340,780 enhanced font 'sans,11' dynamic
set output 'diagnose-power.svg'
set datafile separator ','
set multiplot layout 2,3 title 'diagnose: detection probability against effect size (Clopper-Pearson 95 % bars)'
set yrange [-0.05:1.05]
set ylabel 'detection probability'
set key bottom right
set grid
set offsets graph 0.08, graph 0.08, 0, 0
set xtics ('700000' 700000, '1000000' 1000000)
set title 'second_class' noenhanced
set xlabel 'K2' noenhanced
plot 'diagnose-power.csv' skip 1 using (strcol(1) eq 'second_class' && $4 == 50 ? $3 : NaN):7:8:9 with yerrorlines title '50 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'second_class' && $4 == 100 ? $3 : NaN):7:8:9 with yerrorlines title '100 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'second_class' && $4 == 400 ? $3 : NaN):7:8:9 with yerrorlines title '400 trucks'
set xtics ('1.02' 1.02, '1.05' 1.05)
set title 'sensor_gain' noenhanced
set xlabel 'gain' noenhanced
plot 'diagnose-power.csv' skip 1 using (strcol(1) eq 'sensor_gain' && $4 == 50 ? $3 : NaN):7:8:9 with yerrorlines title '50 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'sensor_gain' && $4 == 100 ? $3 : NaN):7:8:9 with yerrorlines title '100 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'sensor_gain' && $4 == 400 ? $3 : NaN):7:8:9 with yerrorlines title '400 trucks'
set xtics ('1.02' 1.02, '1.05' 1.05)
set title 'speed_bias' noenhanced
set xlabel 'factor' noenhanced
plot 'diagnose-power.csv' skip 1 using (strcol(1) eq 'speed_bias' && $4 == 50 ? $3 : NaN):7:8:9 with yerrorlines title '50 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'speed_bias' && $4 == 100 ? $3 : NaN):7:8:9 with yerrorlines title '100 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'speed_bias' && $4 == 400 ? $3 : NaN):7:8:9 with yerrorlines title '400 trucks'
set xtics ('1000' 1000, '2000' 2000)
set title 'tyre_damping' noenhanced
set xlabel 'c_t' noenhanced
plot 'diagnose-power.csv' skip 1 using (strcol(1) eq 'tyre_damping' && $4 == 50 ? $3 : NaN):7:8:9 with yerrorlines title '50 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'tyre_damping' && $4 == 100 ? $3 : NaN):7:8:9 with yerrorlines title '100 trucks', 'diagnose-power.csv' skip 1 using (strcol(1) eq 'tyre_damping' && $4 == 400 ? $3 : NaN):7:8:9 with yerrorlines title '400 trucks'
set title 'clean logs: false alarms' noenhanced
set xlabel 'trucks'
set ylabel 'false-alarm rate'
set yrange [0:0.25]
set key top right
set xtics ('100' 100, '400' 400)
set arrow from graph 0, first 0.05 to graph 1, first 0.05 nohead dashtype 2
plot 'diagnose-power-false-alarms.csv' skip 1 using 1:4:5:6 with yerrorbars pt 7 title 'pooled per size, 95 % bars', NaN with lines dashtype 2 lc 'black' title 'target 5 %'
unset arrow
unset multiplot
unset output
