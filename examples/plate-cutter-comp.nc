%
O1013 (PLATE 100 X 60: OUTLINE, POCKET AND BORE WITH CUTTER COMPENSATION)
(The drawing: a plate 100 x 60 mm, work zero at its lower left corner, top face Z0.)
(- outline: corners R10 at the top and on the right side, square at the lower left,)
(  milled 10.5 deep;)
(- a pocket 40 x 20 centred at X35 Y30 with corners R8, 5 deep;)
(- a bore of 30 diameter at X80 Y30, 5 deep.)
(The program describes the part, not the tool: O100 mills the three contours under)
(G41 with the D it is given, so one program roughs and finishes, as source 004's)
(contour approach teaches. Roughing: T1 with D4 = radius 5.0 + 0.3 allowance, so 0.3 mm stays on)
(every wall. Finishing: T2 with D2 = radius 3.3 takes the walls to size. The outline)
(is climb-milled clockwise round the outside, the pocket and the bore)
(counter-clockwise inside, always with G41. Each start-up move is a G1 from a point)
(farther than the radius from the contour; each contour runs on past its start point)
(so that no wall is left where the start-up joint turned inside, and ends with a G40)
(G1 move away from the wall.)
N10 G21 G90 G17 G94 G54 G40 G49 G80
N20 T1 M6
N30 G43 H1 G0 Z50.
N40 M3 S4500
N50 G65 P100 D4. F800. (ROUGHING, 0.3 MM LEFT)
N60 G0 Z50.
N70 T2 M6
N80 G43 H2 G0 Z50.
N90 M3 S6000
N100 G65 P100 D2. F500. (FINISHING TO SIZE)
N110 G49 G0 Z50. M5 (TOOL LENGTH OFF: Z50 IN MACHINE TERMS, AS EVERY EXAMPLE ENDS)
N120 M30
O100 (THE THREE CONTOURS OF THE DRAWING: D = #7, F = #9)
(outline)
N200 G0 X-15. Y-15.
N210 G0 Z2.
N220 G1 Z-10.5 F300.
N230 G41 D#7 G1 X0 Y-10. F#9
N240 G1 Y50.
N250 G2 X10. Y60. I10. J0
N260 G1 X90.
N270 G2 X100. Y50. I0 J-10.
N280 G1 Y10.
N290 G2 X90. Y0 I-10. J0
N300 G1 X-10.
N310 G40 G1 X-15. Y-15.
N320 G0 Z2.
(pocket)
N330 G0 X35. Y30.
N340 G1 Z-5. F300.
N350 G41 D#7 G1 Y20. F#9
N360 G1 X47.
N370 G3 X55. Y28. I0 J8.
N380 G1 Y32.
N390 G3 X47. Y40. I-8. J0
N400 G1 X23.
N410 G3 X15. Y32. I0 J-8.
N420 G1 Y28.
N430 G3 X23. Y20. I8. J0
N440 G1 X45.
N450 G40 G1 X35. Y30.
N460 G0 Z2.
(bore)
N470 G0 X80. Y30.
N480 G1 Z-5. F300.
N490 G41 D#7 G1 Y15. F#9
N500 G3 J15.
N505 G3 X95. Y30. I0 J15.
N510 G40 G1 X80. Y30.
N520 G0 Z2.
M99
%
