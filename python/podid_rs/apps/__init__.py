"""What the ``podid-rs`` command line runs: :mod:`.cli` parses, :mod:`.paper` runs the
paper's Section 6 study, :mod:`.identify` identifies a model from measured data."""
