// M10x1.5 thread 30 mm deep in four passes (12, then 8 and 8, then the remaining 2 mm),
// backing out 2 mm between passes; the same check as the source's main program.
// Fits the shipped machine (Z -250..50).
#use "metch_cycles.c"
G90 G54
Tapping("Z", "C", 40, 0, 5, 30, 12, 2, 8, 1.5, 300, 600, 2, 40);
$dPerm[1] = @ITPPATH;
$dPerm[3] = fabs(@ITPPATH - $dPerm[2]);
if ($dPerm[3] > 0.1)
{
    terminate(5559, "dPath i ITPPATH ne ravni!");
}
MSG("passes: " + $nTapPasses + ", path " + $dTapPath + " mm");
M02
