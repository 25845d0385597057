0 BEGIN PGM CONTOUR MM
1 ; Plate 80 x 50, work zero at its lower left corner, top face Z0. The outline is milled
2 ; 6 deep in two passes of Q1, climb-milled clockwise round the outside under RL:
3 ; corner R5 at the lower left (RND), a 6 mm chamfer at the upper left (CHF), an arc
4 ; tangent to the top edge down to X80 Y30 (CT), a R15 corner at the lower right (CR).
5 BLK FORM 0.1 Z X+0 Y+0 Z-10
6 BLK FORM 0.2 X+80 Y+50 Z+0
7 Q1 = -3 ; DEPTH OF ONE PASS
8 Q2 = +0 ; DEPTH REACHED
9 Q3 = +80 ; PLATE LENGTH
10 Q4 = +50 ; PLATE WIDTH
11 TOOL CALL 2 Z S4000
12 M3
13 L X+20 Y-10 R0 FMAX
14 L Z+5 FMAX
15 LBL 1
16 FN 1: Q2 = +Q2 + +Q1
17 L Z+Q2 F300
18 L X+20 Y+0 RL F600 ; START-UP ONTO THE LOWER EDGE
19 L X+0 Y+0
20 RND R5
21 L Y+Q4
22 CHF 6
23 L X+50
24 CT X+Q3 Y+30
25 L Y+15
26 CR X+65 Y+0 R+15 DR-
27 L X+15
28 L X+15 Y-10 R0 ; AWAY FROM THE WALL
29 CALL LBL 1 REP 1
30 L Z+50 R0 FMAX
31 M30
32 END PGM CONTOUR MM
