"""pre-commit's commit-msg hook: a commit's subject line is at most 72 characters (the
measurements go in the body). Usage: ``python3 .ci/commit_subject.py MESSAGE_FILE``."""

import sys
from pathlib import Path

LIMIT = 72

subject = Path(sys.argv[1]).read_text(encoding="utf-8").partition("\n")[0]
if len(subject) > LIMIT:
    sys.exit(f"commit subject is {len(subject)} characters, at most {LIMIT}: shorten it, put the rest in the body")
