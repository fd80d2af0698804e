"""VLP-16 driver service: the LiDAR's UDP data packets -> one PointCloud per revolution.

Listens for the sensor's packets on ``vlp16.port`` at ``vlp16.bind_address``, gathers and
decodes them with velodyne_decoder (decode.py) and publishes each revolution on ``scan``
(10 Hz at the sensor's default 600 rpm) in frame ``vlp16.frame``, x forward, y left, z up,
stamped with this host's clock at the arrival of its last packet (plus
``vlp16.stamp_offset_s``, for tests of a host whose clock is off). A malformed datagram is
dropped, counted and logged (the first 10, then every 100th); the stream goes on. Holds its
liveliness token once the port is bound. On wall time only: not a lockstep participant.
"""

from __future__ import annotations

from services.vlp16_driver.config import vlp16_section
from services.vlp16_driver.decode import MalformedPacket, RevolutionDecoder
from services.vlp16_driver.receiver import UdpReceiver
from shared.config import ConfigError
from shared.messages import PointCloud
from shared.service import EXIT_CONFIG, Service

NAME = "vlp16_driver"


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, bus = vlp16_section(svc.cfg), svc.bus
        try:
            cfg.validate()
        except ConfigError as exc:
            svc.log.error("config error: %s", exc)
            raise SystemExit(EXIT_CONFIG) from None
        decoder = RevolutionDecoder(cfg.min_range_m, cfg.max_range_m)
        scan_key = svc.declare("publishes", svc.keys.scan)

        def on_datagram(data: bytes, stamp: float) -> None:
            try:
                rev = decoder.feed(data, stamp)
            except MalformedPacket as exc:
                n = decoder.malformed
                if n <= 10 or n % 100 == 0:
                    svc.log.warning("dropped malformed packet (%d so far): %s", n, exc)
                return
            if rev is not None:
                with bus.lock:
                    stamp = rev.stamp + cfg.stamp_offset_s  # tests: a host clock that far off
                    bus.publish(scan_key, PointCloud(stamp, cfg.frame, rev.points))

        try:
            receiver = UdpReceiver(
                cfg.bind_address, cfg.port, on_datagram, cfg.receive_buffer_bytes
            )
        except OSError as exc:
            svc.log.error("cannot listen on udp %s:%d: %s", cfg.bind_address, cfg.port, exc)
            raise SystemExit(1) from None
        svc.declare("listens on", f"udp {receiver.address}:{receiver.port}")
        if receiver.buffer_bytes < cfg.receive_buffer_bytes:
            svc.log.warning(
                "receive buffer %d bytes, not the %d asked (raise net.core.rmem_max)",
                receiver.buffer_bytes,
                cfg.receive_buffer_bytes,
            )
        receiver.start()
        try:
            svc.wait()
        finally:
            receiver.close()
            svc.log.info(
                "%d packets, %d malformed, %d revolutions published, %d dropped",
                decoder.packets,
                decoder.malformed,
                decoder.revolutions,
                decoder.dropped,
            )


if __name__ == "__main__":
    main()
