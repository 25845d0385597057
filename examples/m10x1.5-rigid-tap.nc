%
O1001 (M10 X 1.5 RIGID TAP, FOUR HOLES)
(Rigid tapping with G84: Z feeds and the spindle axis C turns as one path, so every)
(millimetre of Z is exactly 360/1.5 = 240 degrees of C, down and back out.)
(M29 S500 selects rigid tapping at 500 rpm; with G94 the feed is pitch x S =)
(1.5 x 500 = 750 mm/min. G98 returns to the initial level Z10 after each hole.)
(Depth 16 mm below the top face Z0, start 3 mm above it at R3.)
N10 G21 G90 G17 G94 G54
N20 G0 X0 Y0 Z10.
N30 M29 S500
N40 G98 G84 X20. Y20. Z-16. R3. F750.
N50 X60.
N60 Y60.
N70 X20.
N80 G80
N90 G0 Z50.
N100 M30
%
