%
O1000 (BASIC MOVES, ARCS, OFFSETS, UNITS)
N10 G21 G90 G17 G94 G54
N20 T3 M6
N30 S1200 M3
N40 G0 X10. Y5. Z5.
N50 G1 Z-1. F200
N60 G1 X30. Y5.
(MSG, ARCS)
N70 G2 X40. Y15. I0 J10.      (three quarters CW, centre 30,15)
N80 G3 X30. Y25. R10.         (quarter CCW by R)
N90 G2 X50. Y25. R-10.        (CW, more than 180 deg: centre 40,25 -- half circle)
N100 G2 X50. Y25. I-5. J0     (full circle, centre 45,25)
N110 G3 X50. Y25. Z-3. I-5.   (helical full turn down 2 mm)
N120 G0 Z5.
N130 G91 G1 X-10. F300        (incremental)
N140 G90
N150 G18 G2 X30. Z-5. I-5. K-5. (ZX plane)
N160 G19 G3 Y35. Z-5. J5. K0 F150 (YZ plane half circle, centre Y30)
N170 G17 G0 Z10.
N180 S2400
N190 G4 X0.5
N200 G4 P250
N210 G55 G0 X0 Y0             (work X zero at machine 100)
N220 G53 G0 Z0
N230 G20 G0 X1. Y1.           (inch)
N240 G1 X2. F10.
N250 G21 G54
N260 M4 S500
N270 M5
N280 M1
N290 M0
N300 M30
%
