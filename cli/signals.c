/* ivoct command line — SIGINT, SIGTERM and SIGHUP (see cli/README.md).
 *
 * main() blocks the three signals before any thread exists, so every thread
 * (OpenMP's, VTK's, TBB's) inherits the mask, and one thread of ours takes
 * them with sigwait().  It runs in a normal context, not in a signal handler:
 * it restores the default actions (a second signal stops the process at once),
 * ends the progress bar's line, removes every temporary file of io/ (which
 * waits for a commit group being renamed, so the outputs are all in place or
 * none is) and re-raises the signal, so that the process ends killed by it and
 * the shell sees 128 + N (130, 143, 129).  SIGXFSZ is ignored, so that a file
 * past `ulimit -f` is a write error (EFBIG) like a full disk, not a kill. */
#define _POSIX_C_SOURCE 200809L
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "../io/io.h"
#include "cli.h"

static sigset_t handled;
static const char *command = "ivoct";
static atomic_int interrupted;
static atomic_int settled; /* cli_signals_settled: nothing to report any more */
static pthread_mutex_t progress_lock = PTHREAD_MUTEX_INITIALIZER;
static int progress_open; /* under progress_lock: a bar without its newline */

int cli_progress_lock(void)
{
    pthread_mutex_lock(&progress_lock);
    if (!atomic_load(&interrupted))
        return 1;
    pthread_mutex_unlock(&progress_lock);
    return 0;
}

void cli_progress_unlock(int line_open)
{
    progress_open = line_open;
    pthread_mutex_unlock(&progress_lock);
}

static void say(const char *s)
{
    ssize_t r = write(2, s, strlen(s));
    (void)r;
}

static void sleep_forever(void)
{
    for (;;) {
        struct timespec ts = {3600, 0};
        nanosleep(&ts, NULL);
    }
}

static void *signal_thread(void *arg)
{
    (void)arg;
    int sig = 0;
    while (sigwait(&handled, &sig) != 0)
        ;
    atomic_store(&interrupted, sig);
    /* from here a second signal takes its default action: it stops at once */
    const int sigs[3] = {SIGINT, SIGTERM, SIGHUP};
    for (int i = 0; i < 3; i++)
        if (sigismember(&handled, sigs[i]) == 1)
            signal(sigs[i], SIG_DFL);
    pthread_sigmask(SIG_UNBLOCK, &handled, NULL);
    /* interrupted is set: a bar being drawn is finished, and no other starts */
    pthread_mutex_lock(&progress_lock);
    if (progress_open)
        say("\n");
    progress_open = 0;
    pthread_mutex_unlock(&progress_lock);
    cli_test_pause("interrupted");
    io_remove_temporaries();
    const char *name = sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "SIGHUP";
    char line[160];
    snprintf(line, sizeof line, "ivoct %s: interrupted by %s\n", command, name);
    if (!atomic_load(&settled))
        say(line);
    raise(sig);
    _exit(128 + sig); /* not reached: the default action ends the process */
}

void cli_signals_start(const char *cmd)
{
    command = cmd;
    signal(SIGXFSZ, SIG_IGN);
    sigemptyset(&handled);
    sigaddset(&handled, SIGINT);
    sigaddset(&handled, SIGTERM);
    sigaddset(&handled, SIGHUP);
    /* a signal the shell started us ignoring (nohup, a background job's
     * SIGINT) stays ignored */
    const int sigs[3] = {SIGINT, SIGTERM, SIGHUP};
    for (int i = 0; i < 3; i++) {
        struct sigaction sa;
        if (sigaction(sigs[i], NULL, &sa) == 0 && sa.sa_handler == SIG_IGN)
            sigdelset(&handled, sigs[i]);
    }
    if (pthread_sigmask(SIG_BLOCK, &handled, NULL) != 0)
        return;
    pthread_t th;
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    if (pthread_create(&th, &attr, signal_thread, NULL) != 0)
        pthread_sigmask(SIG_UNBLOCK, &handled, NULL); /* no thread: default actions */
    pthread_attr_destroy(&attr);
}

void cli_signals_settled(void) { atomic_store(&settled, 1); }

int cli_signals_finish(int rc)
{
    /* a signal is being handled: let its thread end the process with it,
     * rather than exit with what the interrupted work returned */
    if (atomic_load(&interrupted))
        sleep_forever();
    return rc;
}

void cli_test_pause(const char *step)
{
    const char *at = getenv("IVOCT_TEST_PAUSE_AT");
    size_t n = strlen(step);
    /* a comma-separated list of steps: pause at each of them */
    while (at && !(strncmp(at, step, n) == 0 && (at[n] == ',' || at[n] == 0))) {
        at = strchr(at, ',');
        if (at)
            at++;
    }
    if (!at)
        return;
    char line[160];
    snprintf(line, sizeof line, "ivoct: test pause at %s\n", step);
    say(line);
    sleep_forever();
}
