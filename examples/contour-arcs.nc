%
O1004 (CONTOUR WITH ARCS AND A HELIX)
(A 60 x 40 mm pocket outline with 10 mm corner radii, milled at Z-2 with G1, G2 and)
(G3 moves (the rounded slot end on the right is a G3 bulge), then a helical entry)
(into a 20 mm bore at X100 Y0: two full turns of G3 with I, dropping 1.5 mm per turn,)
(and a final flat circle at the bottom. Arcs and helices are sampled on the true curve.)
N10 G21 G90 G17 G94 G54
N20 M3 S6000
N30 G0 X10. Y0 Z5.
N40 G1 Z-2. F300.
N50 G1 X50. F900.
N60 G3 X60. Y10. I0 J10.
N70 G1 Y15.
N80 G3 X60. Y25. I0 J5.
N90 G1 Y30.
N100 G3 X50. Y40. I-10. J0
N110 G1 X10.
N120 G3 X0 Y30. I0 J-10.
N130 G1 Y10.
N140 G3 X10. Y0 I10. J0
N150 G2 X20. Y10. I0 J10.
N160 G0 Z5.
N170 G0 X110. Y0
N180 G1 Z0 F300.
N190 G3 X110. Y0 Z-1.5 I-10. J0 F600.
N200 G3 X110. Y0 Z-3. I-10. J0
N210 G3 X110. Y0 I-10. J0
N220 G0 Z50.
N230 M5
N240 M30
%
