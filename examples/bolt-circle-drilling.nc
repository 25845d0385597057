%
O1003 (BOLT CIRCLE: SPOT WITH G81, PECK DRILL WITH G83)
(Six holes on a 80 mm bolt circle around X50 Y30, every 60 degrees from 0.)
(Tool 1 spots each hole 1 mm deep with G81 returning to R (G99); tool 2 drills them)
(12 mm deep with G83, pecks of Q3 with full retract to R between pecks, returning)
(to the initial level Z10 after the last hole (G98).)
(Hole positions: X = 50 + 40 cos(a), Y = 30 + 40 sin(a), a = 0, 60, ... 300.)
N10 G21 G90 G17 G94 G54
N20 T1 M6
N30 M3 S2500
N40 G0 X90. Y30. Z10.
N50 G99 G81 X90. Y30. Z-1. R2. F250.
N60 X70. Y64.641
N70 X30. Y64.641
N80 X10. Y30.
N90 X30. Y-4.641
N100 G98 X70. Y-4.641
N110 G80 M5
N120 T2 M6
N130 M3 S1800
N140 G0 X90. Y30. Z10.
N150 G99 G83 X90. Y30. Z-12. R2. Q3. F180.
N160 X70. Y64.641
N170 X30. Y64.641
N180 X10. Y30.
N190 X30. Y-4.641
N200 G98 X70. Y-4.641
N210 G80 M5
N220 G0 Z50.
N230 M30
%
