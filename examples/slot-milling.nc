%
O1253 (TWO SLOTS WITH SOURCE 003'S SLOT-MILLING CYCLE, A CUSTOM MACRO B PROGRAM)
(O9253 below is the cycle: a call names the slot and its cutting data, the program does)
(source 003's algorithm: to the centre, to the set-up clearance, a pendulum plunge along)
(the slot to the next layer, the layer milled round the slot, back up, again until the)
(roughing depth; then, with a wall or floor allowance, one finishing pass at full depth)
(round the finished outline; last, up to the 2nd set-up clearance. The slot lies along X.)
(cnc402 post carries the call and the program to a target with Macro B; on others the)
(post writes the moves it makes.)
N10 G21 G90 G17 G94 G54 G40 G49 G80
N20 T1 M6
N30 G43 H1 G0 Z50.
N40 M3 S3000
N50 G0 X30. Y20.
(a 40 x 12 slot 6 deep, 2 a layer, 0.2 left on the walls and 0.1 on the floor)
N60 G65 P9253 X30. Y20. A40. B12. D10. W0 Z-6. Q2. R2. K50. C0.2 I0.1 F600. E150.
(a 60 x 14 slot 4 deep, roughed only)
N70 G65 P9253 X30. Y45. A60. B14. D10. W0 Z-4. Q2. R2. K50. F600. E150.
N80 G0 Z50. M5
N90 M30
O9253 (SLOT MILLING, SOURCE 003)
(X Y centre, A length, B width, D tool diameter, W surface, Z bottom, Q layer depth,)
(R set-up clearance, K 2nd set-up clearance, C wall and I floor allowance, F E feeds)
IF [#17 LE 0] THEN #3000=1 (Q MUST BE ABOVE 0)
#30=[#2-#7]/2-#3
#31=[#1-#2]/2
IF [#30 LE 0] THEN #3000=2 (SLOT NOT WIDER THAN THE TOOL)
#27=#26+#4
#32=#23
G0 X#24 Y#25
WHILE [#32 GT #27] DO1
#33=#32
#32=#32-#17
IF [#32 LT #27] THEN #32=#27
G0 Z[#33+#18]
G1 Z#33 F#8
G1 X[#24+#31] Z[[#33+#32]/2]
G1 X[#24-#31] Z#32
G1 X#24
G1 Y[#25-#30] F#9
G1 X[#24+#31]
G3 Y[#25+#30] I0 J#30
G1 X[#24-#31]
G3 Y[#25-#30] I0 J[-#30]
G1 X#24
G1 Y#25
G0 Z[#23+#18]
END1
#28=#3+#4
WHILE [#28 GT 0] DO2
#28=0
#29=#30+#3
G1 Z#26 F#8
G1 Y[#25-#29] F#9
G1 X[#24+#31]
G3 Y[#25+#29] I0 J#29
G1 X[#24-#31]
G3 Y[#25-#29] I0 J[-#29]
G1 X#24
G1 Y#25
G0 Z[#23+#18]
END2
G0 Z[#23+#6]
M99
%
