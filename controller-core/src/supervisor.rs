//! Firmware safety logic: arming, fault handling and watchdog feeding, hardware-free so
//! that host tests exercise it.
