"""The studio: command-line interface, figures and reports."""
