"""The imperative shell: Zenoh, MAVLink, recording and web adapters (later issues)."""
