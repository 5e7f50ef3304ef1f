"""``python -m mmocap``: the ``mmocap`` command (:func:`mmocap.cli.main`)."""

from mmocap.cli import main

main()
