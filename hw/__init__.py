"""twmr.hw: CAN motor drives (protocols, drive component, emulator, safety)."""
