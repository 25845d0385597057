while (1) { MSG("x"); }
