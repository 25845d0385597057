//! simdrive and the vcan hardware-in-the-loop suite (filled in by the SocketCAN issue).
