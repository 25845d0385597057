%
O2001 (TWO SPINDLES: BOTH TURNING, THEN A RIGID TAP ON EACH)
(Spindle 1 is C, spindle 2 is U. P on an S/M3/M4/M5/M19 block selects the spindle and)
(stays selected until the next P, as Fanuc's multi-spindle control does.)
N10 G21 G90 G17 G94 G54
N20 G0 X0 Y0 Z10. A0 B0
N30 M3 S2000 P1 (spindle 1 at 2000 rpm)
N40 M4 S1500 P2 (spindle 2 at 1500 rpm ccw; spindle 1 keeps turning)
N50 G1 X40. Y20. A15. B-10. F3000. (both spindles turn while the axes move)
N60 M5 (stops spindle 2, the selected one)
N70 M5 P1 (stops spindle 1)
N80 G0 X20. Y20. A0 B0
N90 M29 S800 P2 (rigid tap on spindle 2: Z and U coupled, M10 x 1.5)
N100 G98 G84 X20. Y20. Z-16. R3. F1200.
N110 X60.
N120 G80
N130 M29 S500 P1 (the same tap on spindle 1: Z and C)
N140 G98 G84 X20. Y60. Z-16. R3. F750.
N150 G80
N160 G0 Z50.
N170 M30
%
