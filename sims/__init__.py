"""Co-simulation master, scenarios, metrics, plots and the CLI."""
