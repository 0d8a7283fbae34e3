"""Run machinery: episodes as rows (``episodes``), where they run (``backends``: worker
processes or Ray), checkpoints of a search (``checkpoint``)."""
