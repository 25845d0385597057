%
O1
(Fräse Ø 10)
G0 X1
M30
%
