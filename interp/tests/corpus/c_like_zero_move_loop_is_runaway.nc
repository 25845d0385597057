G90 G0 X0
while (1) {
G0 X0
}
