"""What a launcher's processes know it by: the variable that names its pid to its children, and
the module its warm parent runs (docs/startup.md).

Apart from ``service_names`` because the launcher's first act, starting its warm parent
(``services/launcher/warm_parent.py``), needs these two and nothing more: ``service_names``
brings ``dataclasses`` and ``typing``, 11 ms of CPU that the warm parent's start, which every
service's start waits on, would otherwise wait for.
"""

PARENT_PID_ENV = "MOTOCELL_PARENT_PID"
"""Set by ``motocell up`` for its children: they stop when that process goes away."""
WARM_PARENT_MODULE = "motocell.services.launcher.zygote"
"""The launcher's warm parent, which the services are forked from (docs/startup.md): a process
of the cell beside them, but no service."""
