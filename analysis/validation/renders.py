"""Where the validation scripts keep their renders: one folder per use, tied to the build.

In: a `facslab` binary and a folder. Out: the folder, emptied if its renders came from another
build. Invariant: a folder never holds renders of two different binaries, so a table that reuses
renders (the scripts render only what is missing) never mixes builds.
"""
import hashlib
import os
import shutil


def renders_of(facslab, folder):
    """Makes `folder` the place for renders of this `facslab` binary: renders kept there by an
    earlier run are reused only if that run used a binary with the same bytes (its SHA-256 is
    kept in `folder/BUILD`); otherwise they are deleted, so a table never mixes builds."""
    with open(shutil.which(facslab) or facslab, "rb") as f:
        build = hashlib.sha256(f.read()).hexdigest()
    stamp = os.path.join(folder, "BUILD")
    if os.path.isdir(folder):
        kept = open(stamp).read().strip() if os.path.exists(stamp) else None
        if kept != build:
            shutil.rmtree(folder)
    os.makedirs(folder, exist_ok=True)
    with open(stamp, "w") as f:
        f.write(build + "\n")
    return folder
