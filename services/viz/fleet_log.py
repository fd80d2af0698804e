"""What the viz node does with each message: the state kept between messages (the latest
pose estimate, the floor shown, recent ground truth) and the rerun_log call. No Zenoh, so
tests drive it with the node's own logic."""

from __future__ import annotations

from services.viz import rerun_log
from shared.config import Footprint
from shared.messages import Odometry, Path, PointCloud, PoseEstimate, RouteReply
from shared.site import Site


class TruthByStamp:
    """The last ``size`` ground-truth messages by the stamp of their tick.

    The truth and the estimate of one tick arrive on different keys, the truth usually
    first; comparing an estimate with whatever truth came last would count the chair's
    motion in between as localisation error.
    """

    def __init__(self, size: int = 200) -> None:
        self.size = size
        self._by_stamp: dict[float, Odometry] = {}

    def add(self, msg: Odometry) -> None:
        """Keep ``msg``, forgetting the oldest beyond ``size``."""
        self._by_stamp[round(msg.stamp, 6)] = msg
        if len(self._by_stamp) > self.size:
            self._by_stamp.pop(next(iter(self._by_stamp)))

    def at(self, stamp: float) -> Odometry | None:
        """The truth of the tick at ``stamp``, None if not (or no longer) known."""
        return self._by_stamp.get(round(stamp, 6))


class FleetLog:
    """Logs the fleet's messages; messages that need context get it here."""

    def __init__(
        self,
        footprint: Footprint,
        site: Site | None = None,
        start_floor: str = "",
        scan_band_m: float | None = None,
    ) -> None:
        self.footprint = footprint
        self.scan_band_m = scan_band_m  # the scan points shown: this near the sensor's height
        self.site = site
        self.start_floor = start_floor  # for estimates that name no floor
        self.floor = ""  # the floor whose map is shown
        self.pose: PoseEstimate | None = None
        self.truths = TruthByStamp()

    def show_floor(self, name: str, stamp: float) -> None:
        """Show floor ``name``'s map from ``stamp`` on, if it is a new floor of the site.

        From the first estimate's stamp, not from 0: on a chair's wall clock a map at 0
        would stretch the timeline over decades."""
        if self.site is None or name == self.floor or name not in self.site.floors:
            return
        self.floor = name
        rerun_log.log_site(self.site, self.site.floors[name], stamp)

    @property
    def stamp(self) -> float:
        """The time of messages without a stamp of their own: the latest estimate's."""
        return self.pose.stamp if self.pose is not None else 0.0

    def on_pose(self, msg: PoseEstimate) -> None:
        """The estimate with its footprint, its error against the truth, and its floor's map."""
        self.pose = msg
        self.show_floor(msg.pose.floor or self.start_floor, msg.stamp)
        rerun_log.log_pose(msg, self.footprint)
        truth = self.truths.at(msg.stamp)
        if truth is not None:
            rerun_log.log_localisation_error(msg, truth)

    def on_truth(self, msg: Odometry) -> None:
        self.truths.add(msg)
        rerun_log.log_truth(msg, self.footprint)

    def on_scan(self, msg: PointCloud) -> None:
        rerun_log.log_scan(msg, self.pose, self.scan_band_m)

    def on_path(self, msg: Path) -> None:
        rerun_log.log_path(msg, self.stamp)

    def on_route(self, msg: RouteReply) -> None:
        rerun_log.log_route(msg, self.stamp)
