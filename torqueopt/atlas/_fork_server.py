"""Imported by multiprocessing's fork server, which forks the atlas's Dask workers, and nowhere else.

Ctrl-C goes to the whole process group, the workers included; each printed a KeyboardInterrupt traceback,
or failed the cluster's start with one. The fork server gives each child the SIGINT disposition it had
when its preloaded modules were imported, so this module ignores SIGINT there: the workers never hear it,
and the main process alone turns it into ``torqueopt atlas: interrupted`` (:func:`torqueopt.atlas.sweep.executor`).
The server is spawned with SIGINT blocked (:func:`torqueopt.atlas.sweep.start_fork_server`), so that a Ctrl-C
during its imports is not heard either; once ignored, SIGINT is unblocked (a pending one is dropped), and the
workers start with the usual signal mask.
"""

import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
