while (1) { sleep(0); }
