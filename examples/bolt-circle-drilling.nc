%
O1003 (BOLT CIRCLE: SPOT WITH G81, PECK DRILL WITH G83)
(Six holes on a 80 mm bolt circle around X50 Y30, every 60 degrees from 0.)
(Tool 1 spots each hole 1 mm deep with G81 returning to R (G99); tool 2 drills them)
(12 mm deep with G83, pecks of Q3 with full retract to R between pecks. The hole)
(positions are computed with Custom Macro B: X = #1 + #3 COS(a), Y = #2 + #3 SIN(a).)
#1 = 50. (CENTER X)
#2 = 30. (CENTER Y)
#3 = 40. (RADIUS)
#4 = 6 (HOLES)
N10 G21 G90 G17 G94 G54
N20 T1 M6
N30 M3 S2500
N40 G0 X[#1 + #3] Y#2 Z10.
N50 G99 G81 X[#1 + #3] Y#2 Z-1. R2. F250.
#10 = 1
WHILE [#10 LT #4] DO1
#11 = #10 * 360 / #4
X[#1 + #3 * COS[#11]] Y[#2 + #3 * SIN[#11]]
#10 = #10 + 1
END1
N110 G80 G0 Z10. M5
N120 T2 M6
N130 M3 S1800
N140 G0 X[#1 + #3] Y#2 Z10.
N150 G99 G83 X[#1 + #3] Y#2 Z-12. R2. Q3. F180.
#10 = 1
WHILE [#10 LT #4] DO1
#11 = #10 * 360 / #4
X[#1 + #3 * COS[#11]] Y[#2 + #3 * SIN[#11]]
#10 = #10 + 1
END1
N210 G80 G0 Z10. M5
N220 G0 Z50.
N230 M30
%
