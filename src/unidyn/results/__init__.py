"""What a run gives back and how it is kept: :class:`~unidyn.Result`
(:mod:`~unidyn.results.result`), the results folders a command writes into
(:mod:`~unidyn.results.folders`), the paper's figure types
(:mod:`~unidyn.results.plots`) in unidyn's figure style
(:mod:`~unidyn.results.figstyle`), and a run written as a ROS bag
(:mod:`~unidyn.results.rosbag`)."""
