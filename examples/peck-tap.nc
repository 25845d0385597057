%
O1002 (PECK TAP M8 X 1.25, DEEP HOLE)
(Peck tapping: G84 with Q goes in by Q = 4 mm per peck, backs out by the configured)
(peck_retract to clear chips, and goes in again, Z and C coupled through every)
(reversal. G95 gives the feed per revolution, so F is the pitch: 1.25 mm.)
(M29 S600: rigid tapping at 600 rpm. Thread depth 20 mm below Z0.)
N10 G21 G90 G17 G54
N20 G0 X-30. Y15. Z10.
N30 M29 S600
N40 G95 G99 G84 X-30. Y15. Z-20. R2. Q4. F1.25
N50 X-50.
N60 G80 G94
N70 G0 Z50.
N80 M30
%
