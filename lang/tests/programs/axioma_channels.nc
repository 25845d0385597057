int nCh = 1; // выбор рабочего канала
int nPartProgNo = 2; // количество программ
string chanProgs[nPartProgNo]; // содержит имена запускаемых УП
chanProgs[0] = "01.nc";
chanProgs[1] = "02.nc";
if(@CH[0].MODE != 1)
{
    terminate(5554, "Канал не в режиме Авто"); //сообщение о некорректно выбранном режиме
}
MSG("Auto mode");
if(@CH[0].STATE != 2)
{
    terminate(5555, "Neverное состояние канала"); //некорректное состояние канала.
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
