// regression_test.nc (source 000's regression-test program; its head comment lists the
// typo fixes) with a third part program that fails on purpose: 03_zero_feed.nc has a motion
// block without a feed, so its run fails, the retry after channel_reset fails again, and this
// program ends with `terminate 5558: Ne udalos zapustit` (the seed's "interpreter reports an
// error" case). 01.nc and 02.nc run first and pass.
int Iterator;
int msSleep = 1;
int nCh = 1; // выбор рабочего канала
int nPartProgNo = 3; // количество программ
string chanProgs[nPartProgNo]; // содержит имена запускаемых УП
chanProgs[0] = "01.nc";
chanProgs[1] = "02.nc";
chanProgs[2] = "03_zero_feed.nc";

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
