"""Processor in the loop (``rrr hil pil``): the controller as firmware on a Cortex-M under QEMU,
talking SLCAN to the CAN bench's plant node. ``firmware`` (the targets, the images, their sizes,
the run block), ``loop`` (QEMU, the SLCAN bridge, the run), ``results`` (the target's figures
in summary.json)."""
