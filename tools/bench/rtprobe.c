/* How late this machine wakes a bare real-time thread: the floor under the executor's clock.
 *
 *   gcc -O2 -o /tmp/rtprobe tools/bench/rtprobe.c && sudo /tmp/rtprobe 60
 *
 * One SCHED_FIFO thread (priority 50, as the executor's clock) with 1 ns timer slack sleeps to
 * absolute 4 ms deadlines on CLOCK_MONOTONIC for the given seconds: no Python, no Zenoh, no
 * work. Each period it wakes a whole period or more late is printed with its deadline (the
 * clock the executor's Tick.deadline_ns uses, so the two can be matched), then a summary.
 * docs/realtime.md has what it measured here.
 */
#define _GNU_SOURCE
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/prctl.h>
#include <time.h>

static const long long PERIOD_NS = 4000000;

static long long now_ns(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1000000000LL + t.tv_nsec;
}

static int by_value(const void *a, const void *b) {
    long long x = *(const long long *)a, y = *(const long long *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    int seconds = argc > 1 ? atoi(argv[1]) : 60;
    int ticks = seconds * (int)(1000000000LL / PERIOD_NS);
    struct sched_param priority = {.sched_priority = 50};
    if (ticks <= 0 || sched_setscheduler(0, SCHED_FIFO, &priority) != 0) {
        fprintf(stderr, "rtprobe: needs a positive duration and SCHED_FIFO (run as root)\n");
        return 2;
    }
    prctl(PR_SET_TIMERSLACK, 1);
    long long *late = malloc(sizeof *late * (size_t)ticks);
    int missed = 0;
    long long deadline = now_ns() + PERIOD_NS;
    for (int i = 0; i < ticks; i++, deadline += PERIOD_NS) {
        struct timespec at = {deadline / 1000000000LL, deadline % 1000000000LL};
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &at, NULL);
        late[i] = now_ns() - deadline;
        if (late[i] >= PERIOD_NS) {
            missed++;
            printf("missed: deadline %lld ns, %.2f ms late\n", deadline, late[i] / 1e6);
        }
    }
    qsort(late, (size_t)ticks, sizeof *late, by_value);
    printf("ticks %d  lateness p50 %.1f us  p99 %.1f us  max %.2f ms  missed %d\n", ticks,
           late[ticks / 2] / 1e3, late[ticks * 99 / 100] / 1e3, late[ticks - 1] / 1e6, missed);
    free(late);
    return 0;
}
