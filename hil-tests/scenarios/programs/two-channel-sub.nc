(HIL 15: channel 1 of the two-channel machine: U W, in the same loop as channel 0)
G21 G90 G94
G0 U15. W-5.
G1 U60. W-20. F2400.
G1 U30. F1800.
M100 P12 (wait for channel 0 at its M100)
G0 U25. W0.
M30
