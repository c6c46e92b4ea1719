"""The web server: static page, robot and world files, rosbridge endpoint (layer 5)."""
