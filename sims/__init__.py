"""Co-simulation master, disturbance profiles, scenarios, metrics, plots and the CLI."""
