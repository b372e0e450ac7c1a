"""The broad phase: sweep-and-prune with cached pair events (``sap``), its grid columns and
kernels, the pair hash set, and the fat and tight world boxes it sorts (``bounds``)."""
