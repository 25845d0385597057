%
O7002 (HIL: SPINDLE AT 6000 RPM FOR 25 S, ACROSS THE INT32 WRAP OF THE POSITION)
(With machine-vcan-wrap.toml, C has 2^20 counts/rev: 2^31 counts = 2048 rev,)
(reached after about 21 s at 100 rev/s.)
N10 G21 G90 G94 G54
N20 M3 S6000
N30 G4 X25.
N40 M5
N50 M30
%
