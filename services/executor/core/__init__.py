"""The executor's decisions: no Zenoh, sockets, threads or clocks; every time is passed in
(CLOCK_MONOTONIC nanoseconds). ``executor.ExecutorCore`` decides each tick, ``states`` whether
anything may move, ``rings`` what each group has queued, ``queue_cadence`` when a queue state
goes out, ``resting`` when the clock rests, ``start`` where the robot starts."""
