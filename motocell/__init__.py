"""motocell: a MotoROS-compatible robot controller for simulated Yaskawa Motoman cells."""
