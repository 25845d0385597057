(HIL 15: channel 0 of the two-channel machine: X Y Z, while channel 1 moves U W)
G21 G90 G17 G94 G54
G0 X20. Y10. Z5.
G1 X60. Y30. F3000.
G2 X80. Y10. I10. J-10. F2400.
G1 Z-2. F600.
M100 P12 (wait for channel 1 at its M100)
G0 Z10.
G0 X40. Y20.
M30
