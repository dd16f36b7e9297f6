"""The gateway: the motion and I/O ports' Simple Message over TCP, answered from what it holds
of the cell (``core``) and forwarded over Zenoh.

It has no single loop: each port's client is served on a thread of its own, so a reply never
waits behind the other port's request. Each thread lives in the module that starts it:

- ``tcp.RequestServer``, per port: an accept thread, and one thread for the connected client
  that reads its requests, has ``core`` decide each, and writes the replies;
- ``zenoh_cell.ZenohCell``: the watchdog, which forgets state that stopped arriving, subscribes
  to it again, and asks for a missing slot or the controller's liveliness token;
- ``reporter.Reporter``: the connections notice and the metrics, every ``REFRESH_S``.

Zenoh's own threads run the controller status callback and the command and slot answers
(``bus.ZenohBus``); they only decode and hand on, under ``ZenohCell``'s lock.
"""
