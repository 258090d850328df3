"""The logs of the CAN bench's runs, every profile: ``frames`` (the nodes' own frame logs, and
them as Vector ASC / BLF), ``specs`` (the nodes' CSV logs, specified column by column) and
``mcap`` (a run as MCAP)."""
