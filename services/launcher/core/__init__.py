"""The launcher's decisions, no processes: which services a cell runs here and with which command
lines (``children``), its TCP ports (``tcp_ports``), where its router listens (``endpoints``),
and when a child that died comes back (``restarts``, from the table in ``states``)."""
