"""Files: Universal Files (:mod:`.uff`) and ``.npz`` data sets and models (:mod:`.npz`)."""
