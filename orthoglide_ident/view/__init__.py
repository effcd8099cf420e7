"""What a Foxglove view of the product shows, without rclpy: the live viewer node and the
report's MCAP share it.

- ``schemas``: the JSON channels (JSON schema + message builder per topic), stamps as
  ``{sec, nanosec}``, one plottable number per gain and per σ;
- ``server``: the Foxglove WebSocket server (foxglove-sdk, subprotocol ``foxglove.sdk.v1``);
- ``decimate``: one message per period of the stamps, for a browser;
- ``residual``: the measured force g_τ v_τ against the identified model's, live;
- ``convergence``: the drive gains ± σ as the records accumulate (IDIM-TLS on their beginnings);
- ``report_mcap``: ``orthoglide-ident report --mcap FILE``.
"""
