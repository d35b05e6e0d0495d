//! Analysis: responses + ground truth in, statistics out. Knows nothing of HTTP or SQLite.
