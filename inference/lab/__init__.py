"""A lab's files read into the studio's experiment folder: DIC exports (MatchID, DuoDIC, CSV
columns), load-frame records (vendor layouts, units, holds at any sampling rate, the contact
point, drift), the clocks of the two, and the importer that brings them together
(``experiment_import``; what it is told, ``import_sources``). The folder's format and its writer are :mod:`inference.experiment.data`
and :mod:`inference.experiment.folder`."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submod_attrs={
        "experiment_import": [
            "import_dic_csv",
            "import_duodic",
            "import_experiment",
            "import_load_frame",
            "import_matchid",
        ],
        "import_sources": ["ForceSource", "FrameChoice", "IndenterSource", "ProtocolInfo", "parse_frames"],
        "dic_series": ["DICSeries"],
        "load_frame": ["LoadFrameColumns", "find_holds", "read_load_frame"],
        "import_csv": ["CSVMapping"],
        "csv_text": ["csv_encoding", "csv_reading"],
        "clock_offset": ["find_clock_offset"],
    },
)
