#use "metch_cycles.c"
G90
Tapping("Z", "C", 200, 0, 50, 20, 60, 20, 60, 20, 50, 25, 0, 200);
$dPerm[1] = @ITPPATH;
$dPerm[3] = fabs(@ITPPATH - $dPerm[2]);
if ($dPerm[3] > 0.1)
{
    terminate (5559, "dPath i ITPPATH ne ravni!")
}
M02
