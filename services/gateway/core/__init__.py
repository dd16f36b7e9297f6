"""The gateway's decisions: no Zenoh, sockets, threads or clocks. The rest of the cell comes in
through ``cell_port.CellPort``."""
