set terminal pngcairo size 1100,750 enhanced font 'DejaVu Sans,11' noenhanced
set output 'time_error.png'
set title "Run time against error (small size, reference 142 s)"
set logscale xy
set format x '%g'
set format y '%g'
set xlabel 'run time [s]'
set ylabel 'RMS surface error [mm]'
set grid
set key top right
set offsets graph 0.05, graph 0.2, graph 0.1, graph 0.1
plot 'time_error.dat' index 1 using 1:2 with steps lw 2 lc rgb '#d95f02' title 'Pareto front', \
     '' index 0 using 2:($4 > 0 ? $3 : 1/0) with points pt 7 ps 1.5 lc rgb '#1b9e77' title 'on the front', \
     '' index 0 using 2:($4 > 0 ? 1/0 : $3) with points pt 7 ps 1.5 lc rgb '#7570b3' title 'dominated', \
     '' index 0 using 2:3:1 with labels offset char 0.8, char 0.8 left font ',9' notitle
