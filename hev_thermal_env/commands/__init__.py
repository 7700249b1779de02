"""Command-line subcommands that need only the physics (no strategies)."""
