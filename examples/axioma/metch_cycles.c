// metch_cycles.c: machining cycles in the C-like language (source 000, AxiOMA Control style).
// Used with `#use "metch_cycles.c"`; found next to the program or in interp.library_dir.
//
// Tapping(strToolAx, strSpindleAx, dRetPlane, dRefPlane, dSafeDist, dDepth, dStep1,
//         dStepBack, dStep2, dPitch, dTapFeed, dRetFeed, dExitStep, dZ)
// Rigid, single- or multi-pass tapping. The tool axis feeds into the hole in the negative
// direction; every cutting and retracting move is one G1 block of the tool axis and the
// spindle axis, the spindle turning exactly travel / dPitch * 360 degrees in that block
// (positive into the hole, negative out), so the spindle is back at its start angle at the end.
//
//   strToolAx, strSpindleAx  axis names ("Z", "C")
//   dRetPlane   retract plane, absolute (work coordinates of the tool axis)
//   dRefPlane   surface of the part, absolute
//   dSafeDist   the tap starts and ends each cycle dSafeDist above dRefPlane
//   dDepth      thread length below dRefPlane
//   dStep1      depth of the first pass; dStep1 >= dDepth: one pass to dDepth (a first pass
//               deeper than the thread is cut to the thread length, never deeper; a message
//               says so when dStep1 > dDepth)
//   dStepBack   how far the tap backs out between passes; 0: out to dExitStep instead
//   dStep2      depth of every further pass; the last pass cuts what remains (shorter)
//   dPitch      thread pitch (mm per spindle turn)
//   dTapFeed    feed into the hole, dRetFeed feed out of it (mm/min, tool axis)
//   dExitStep   with dStepBack == 0: the absolute tool-axis position to back out to
//   dZ          the tool-axis position the cycle starts from (the source passes its retract
//               plane): the cycle first rapids there, so the path it computes starts from a
//               known point
//
// The cycle checks its parameters before any motion (terminate 5560..5568) and leaves the
// path it expects @ITPPATH to show afterwards (@ITPPATH at the start plus every move of the
// cycle) in $dPerm[2], where the source's main program compares it, and in $dTapPath.
// The number of passes and the depth of each are left in $nTapPasses and $dTapDepth[1..n].

// One coupled block (G91): the tool axis moves by dTravel (negative: into the hole) and the
// spindle turns -dTravel / dPitch turns. Returns the path length of the block.
double TapMove(string strToolAx, string strSpindleAx, double dTravel, double dPitch, double dFeed)
{
    double dSpindlePath = -dTravel / dPitch * 360.0;
    G1 AXSTR(strToolAx)=dTravel AXSTR(strSpindleAx)=dSpindlePath F=dFeed
    return fabs(dTravel);
}

void Tapping(string strToolAx, string strSpindleAx, double dRetPlane, double dRefPlane,
             double dSafeDist, double dDepth, double dStep1, double dStepBack, double dStep2,
             double dPitch, double dTapFeed, double dRetFeed, double dExitStep, double dZ)
{
    // Parameters first: a wrong one stops the program before any motion.
    double dStartTool = @POS[strToolAx];   // also rejects an unknown axis name
    double dStartSpindle = @POS[strSpindleAx];
    if (strToolAx == strSpindleAx)
        terminate(5560, "Tapping: the tool axis and the spindle axis must differ");
    if (dPitch <= 0)
        terminate(5561, "Tapping: dPitch must be > 0");
    if (dTapFeed <= 0 || dRetFeed <= 0)
        terminate(5562, "Tapping: dTapFeed and dRetFeed must be > 0");
    if (dDepth <= 0 || dStep1 <= 0)
        terminate(5563, "Tapping: dDepth and dStep1 must be > 0 (at least one pass)");
    if (dStep1 < dDepth && dStep2 <= 0)
        terminate(5564, "Tapping: dStep2 must be > 0 when dStep1 < dDepth (passes <= 0)");
    if (dSafeDist < 0 || dStepBack < 0)
        terminate(5565, "Tapping: dSafeDist and dStepBack must be >= 0");
    double dStart = dRefPlane + dSafeDist;
    if (dRetPlane < dStart || dZ < dStart)
        terminate(5566, "Tapping: dRetPlane and dZ must not be below dRefPlane + dSafeDist");
    if (dStepBack == 0 && dStep1 < dDepth && (dExitStep <= dRefPlane - dStep1 || dExitStep > dStart))
        terminate(5567, "Tapping: dExitStep must lie between the first pass depth and dRefPlane + dSafeDist");

    double dPath = @ITPPATH;
    double dNow = dStartTool;
    // To the start position dZ, then to dSafeDist above the surface.
    G90
    G0 AXSTR(strToolAx)=dZ
    dPath += fabs(dZ - dNow);
    G0 AXSTR(strToolAx)=dStart
    dPath += fabs(dStart - dZ);
    dNow = dStart;
    G91

    double dFirst = min(dStep1, dDepth);
    if (dStep1 > dDepth)
        MSG("Tapping: dStep1 " + dStep1 + " > dDepth " + dDepth + ": one pass to " + dDepth);
    double dDone = 0;        // depth reached below dRefPlane
    int nPass = 0;
    double dTol = 1e-6;
    while (dDone < dDepth - dTol)
    {
        double dTarget = dFirst;
        if (nPass > 0)
            dTarget = min(dDone + dStep2, dDepth);
        if (dDepth - dTarget < dTol)
            dTarget = dDepth;
        if (nPass > 0)
        {
            // Back out before the next pass: by dStepBack, or out to dExitStep.
            double dBack = dStepBack;
            if (dStepBack == 0)
                dBack = dExitStep - dNow;
            dPath += TapMove(strToolAx, strSpindleAx, dBack, dPitch, dRetFeed);
            dNow += dBack;
        }
        // Cut to dTarget below the surface.
        double dIn = dNow - (dRefPlane - dTarget);
        dPath += TapMove(strToolAx, strSpindleAx, -dIn, dPitch, dTapFeed);
        dNow -= dIn;
        nPass++;
        $dTapDepth[nPass] = dTarget;
        dDone = dTarget;
    }
    // Out of the hole to the start position, then up to the retract plane.
    dPath += TapMove(strToolAx, strSpindleAx, dStart - dNow, dPitch, dRetFeed);
    G90
    G0 AXSTR(strToolAx)=dRetPlane
    dPath += fabs(dRetPlane - dStart);
    $nTapPasses = nPass;
    $dTapPath = dPath;
    $dPerm[2] = dPath;
}
