// The source-000 tapping cycle as printed, its fragments joined into one function
// (the source elides the function head and the path bookkeeping between them).
void Tapping(string strToolAx, string strSpindleAx, double dRetPlane, double dRefPlane,
             double dSafeDist, double dDepth, double dStep1, double dStepBack, double dStep2,
             double dPitch, double dTapFeed, double dRetFeed, double dExitStep, double dZ)
{
    double dNumRots = (dDepth + dSafeDist) / dPitch;
    double dSpindlePath = dNumRots * 360.0;
    double dPath = 0;
    if (dDepth == dStep1) //если глубина равна шагу один
    {
        dStepBack = dStep1 + dSafeDist;
        G90
        G0 AXSTR(strToolAx)=(dRefPlane + dSafeDist)
        G91
        G1 AXSTR(strToolAx)=-(dStep1 + dSafeDist) AXSTR(strSpindleAx) =dSpindlePath F=dTapFeed
        G1 AXSTR(strToolAx)=(dStepBack) AXSTR(strSpindleAx)=-dSpindlePath F=dRetFeed
        G90
        G0 AXSTR(strToolAx)=dRetPlane
        return;
    }
    G90
    G0 AXSTR(strToolAx)=(dRefPlane + dSafeDist)
    G91
    G1 AXSTR(strToolAx)=-(dStep1 + dSafeDist) AXSTR(strSpindleAx)= dSpindlePath F=dTapFeed
    G1 AXSTR(strToolAx)=(dStepBack) AXSTR(strSpindleAx)=- dSpindlePath F=dRetFeed
    double dSch = (dDepth - dStep1) / dStep2; //количество оставшихся проходов
    double dOst = dDepth - dStep1; //оставшееся расстояние
    for (int iSc = 1; iSc <= dSch; iSc++) //определяет, сколько шагов надо сделать
    {
        G1 AXSTR(strToolAx)=-(dStep2 + dStepBack) AXSTR(strSpindleAx)=dSpindlePath F=dTapFeed
        dOst = dOst - dStep2;
        if ((dSch - iSc) < 1) //есть шаг, который меньше шага 2
        {
            if (dOst == 0) //если остаток равен 0
            {
                G1 AXSTR(strToolAx)=(dDepth + dSafeDist) AXSTR(strSpindleAx)=-dSpindlePath F=dRetFeed
                dPath = dPath + dDepth + dSafeDist;
            }
            else //если остаток не равен 0
            {
                G1 AXSTR(strToolAx)=(dStepBack) AXSTR(strSpindleAx)=-dSpindlePath F=dRetFeed
                G1 AXSTR(strToolAx)=-(dOst + dStepBack) AXSTR(strSpindleAx)=dSpindlePath F=dTapFeed
                G1 AXSTR(strToolAx)=(dDepth + dSafeDist) AXSTR(strSpindleAx)=-dSpindlePath F=dRetFeed
                dPath = dPath + dDepth + dSafeDist;
            }
        }
        else //если нет шага, который меньше шага 2
        {
            G1 AXSTR(strToolAx)=(dStepBack) AXSTR(strSpindleAx)=-dSpindlePath F=dRetFeed
        }
    }
    $dPerm[2] = dPath;
}
