# sbc-pooled: written by ssrfleet reproduce; run `gnuplot sbc-pooled-2core.gp` in this folder
set datafile separator ','
if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {
  set terminal pngcairo size 1400,720 enhanced font 'sans,11' dashed
} else {
  set terminal png size 1400,720
}
set output 'sbc-pooled-2core.png'
set multiplot layout 2,4 title 'SBC rank histograms: R = 200, N = 50 trucks, L = 99 draws, B = 10 bins; grey: 99 % band of a uniform histogram'
set xrange [0:1]
set yrange [0:37]
set xtics 0.5
set style fill solid 0.6 border -1
set boxwidth 0.09
unset key
set xlabel 'rank / (L + 1)'
set title "K  ({/Symbol c}^2 p = 0.627)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:2 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "{/Symbol s}_k  ({/Symbol c}^2 p = 0.834)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:3 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "K_t  ({/Symbol c}^2 p = 0.740)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:4 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "{/Symbol s}_{kt}  ({/Symbol c}^2 p = 0.494)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:5 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "Z  ({/Symbol c}^2 p = 0.981)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:6 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "{/Symbol s}_z  ({/Symbol c}^2 p = 0.071)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:7 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "{/Symbol s}_{IF}  ({/Symbol c}^2 p = 0.750)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:8 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
unset multiplot
unset output
set terminal svg size 1400,720 enhanced font 'sans,11' dynamic
set output 'sbc-pooled-2core.svg'
set multiplot layout 2,4 title 'SBC rank histograms: R = 200, N = 50 trucks, L = 99 draws, B = 10 bins; grey: 99 % band of a uniform histogram'
set xrange [0:1]
set yrange [0:37]
set xtics 0.5
set style fill solid 0.6 border -1
set boxwidth 0.09
unset key
set xlabel 'rank / (L + 1)'
set title "K  ({/Symbol c}^2 p = 0.627)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:2 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "{/Symbol s}_k  ({/Symbol c}^2 p = 0.834)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:3 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "K_t  ({/Symbol c}^2 p = 0.740)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:4 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "{/Symbol s}_{kt}  ({/Symbol c}^2 p = 0.494)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:5 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "Z  ({/Symbol c}^2 p = 0.981)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:6 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "{/Symbol s}_z  ({/Symbol c}^2 p = 0.071)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:7 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
set title "{/Symbol s}_{IF}  ({/Symbol c}^2 p = 0.750)"
plot '+' using 1:(10):(32) with filledcurves lc rgb '#d9d9d9', 'sbc-pooled-2core-histograms.csv' skip 1 using 1:8 with boxes lc rgb '#1f77b4', 20 with lines dt 2 lc rgb 'black'
unset multiplot
unset output
