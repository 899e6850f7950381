"""Controllers shared by the simulator and real robots: PID, KLT tracking, visual servoing."""
