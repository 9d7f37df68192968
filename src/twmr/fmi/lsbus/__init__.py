"""FMI-LS-BUS (layered standard for buses in FMI 3.0): bus operations, terminals and manifests."""
