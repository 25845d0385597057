// Source 000's regression-test program (AxiOMA Control, Martinov & Erdneev), as printed,
// run on channel 0: it checks that the working channel nCh is in Auto and ready, then loads
// and runs each part program there, retrying a failed load or run once after channel_reset
// and a 10 ms sleep, else terminate 5556/5558. It passes when it ends without an error.
// Typos fixed (nothing else changed):
//  1. `Iterator` and `msSleep` were used undeclared: declared below (msSleep = 1 ms, so that
//     `sleep(10 *msSleep)` is the text's 10 ms).
//  2. The mode and state checks read `@CH[0]`; the text says they check the working channel,
//     so they read `@CH[nCh]` (channel 0 is this program's own channel, always running).
//  3. "Neverное" (Latin and Cyrillic mixed) is "Неверное".
//  4. A stray `}` after the last loop closed nothing: removed.
// The part programs 01.nc and 02.nc are next to this file; channel 1's axes are U, V, W.
// regression_test_fails.nc adds one that fails on purpose.
int Iterator;
int msSleep = 1;
int nCh = 1; // выбор рабочего канала
int nPartProgNo = 2; // количество программ
string chanProgs[nPartProgNo]; // содержит имена запускаемых УП
chanProgs[0] = "01.nc";
chanProgs[1] = "02.nc";

if(@CH[nCh].MODE != 1)
{
    terminate(5554, "Канал не в режиме Авто"); //сообщение о некорректно выбранном режиме
}
MSG("Auto mode");

if(@CH[nCh].STATE != 2)
{
    terminate(5555, "Неверное состояние канала"); //некорректное состояние канала.
}
MSG("Kanal gotov");

for(Iterator = 0; Iterator < nPartProgNo; Iterator++)
{
    if(channel_load(nCh, chanProgs[Iterator]) == false) //не удалось загрузить с первого раза
    {
        channel_reset(nCh); //reset канала
        sleep(10 *msSleep);
        if(channel_load(nCh, chanProgs[Iterator]) == false) //ошибка, повторная загрузка не удалась
        {
            terminate(5556, "Ne udalos zagruzit kanal");
        }
        channel_wait(nCh);
    }
    MSG("Kanal zagrujen");

    if(channel_run(nCh, chanProgs[Iterator]) == false) //не удалось запустить с первого раза
    {
        channel_reset(nCh); //reset канала
        sleep(10 *msSleep);
        if(channel_run(nCh, chanProgs[Iterator]) == false) //ошибка, повторный запуск не удался
        {
            terminate(5558, "Ne udalos zapustit");
        }
        channel_wait(nCh);
    }
    MSG("Kanal zapuwen");
}
