%
O7003 (HIL: M10 X 1.5 RIGID TAPS AT 800 AND 2000 RPM)
(Two holes each: G84 at S800 F1200, then at S2000 F3000 -- feed = pitch x S.)
(With machine-vcan-mismatched.toml the spindle drive is slower than Z; the master's)
(dynamics models shape both so their actual positions stay coupled.)
N10 G21 G90 G17 G94 G54
N20 G0 X0 Y0 Z10.
N30 M29 S800
N40 G98 G84 X20. Y20. Z-16. R3. F1200.
N50 X60.
N60 G80
N70 M29 S2000
N80 G98 G84 X20. Y60. Z-16. R3. F3000.
N90 X60.
N100 G80
N110 G0 Z50.
N120 M30
%
