"""The sources of the models: one bibliography, rendered into docs/references.md (``ujfmu.bibliography.markdown``,
checked by tests/test_docs.py) and into every FMU's documentation/index.html.

Cited by key, e.g. [Feng2012], in docstrings and docs. DOIs only where verified; a publisher page otherwise.
"""

from dataclasses import dataclass


@dataclass(frozen=True)
class Reference:
    key: str
    authors: str
    title: str
    venue: str
    year: int
    doi: str = ""
    url: str = ""
    used_for: str = ""

    def text(self) -> str:
        """Authors, "title", venue, year[, DOI or URL]."""
        link = f", doi:{self.doi}" if self.doi else f", {self.url}" if self.url else ""
        return f'{self.authors}, "{self.title}", {self.venue}, {self.year}{link}.'


REFERENCES = (
    Reference("Feng2012", "Changlin Feng, Deshi Wang, Yongyong Zhu",
              "Analysis of Moment Transmitted by Universal Joint in Varying Operating Condition",
              "Advanced Engineering Forum, vols. 2-3, p. 999, Trans Tech Publications", 2012,
              url="https://www.scientific.net/AEF.2-3.999",
              used_for="CardanJoint (Eqs. 1-10, laboratory model)"),
    Reference("Brutti1999", "Carlo Brutti, Ettore Pennestri, Marco Evangelos Biancolini",
              "On the Dynamics of the Transmission with a Double Cardan Joint",
              "Proceedings of the Tenth World Congress on the Theory of Machines and Mechanisms (IFToMM), Oulu, "
              "Finland, June 20-24", 1999,
              used_for="DoubleCardanDriveline, rigid intermediate shaft (section 4); Load (M_u = c omega^2)"),
    Reference("Tchomeni2019", "B. X. Tchomeni, A. A. Alugongo, L. Masu",
              "Modeling and vibration analysis of twin-rotor system interconnected by a Hooke's joint (Part A)",
              "Vibroengineering Procedia, vol. 27, pp. 1-6", 2019,
              used_for="TwinJeffcottRotor (Eqs. 1-11)"),
    Reference("Turla2002", "Vytautas Turla, Igor Iljin",
              "The investigation of dynamics of misaligned units in vehicle transmission",
              "Transport (Vilnius Gediminas Technical University)", 2002,
              used_for="RingCoupling (Eqs. 5-22, Figs. 3-4)"),
    Reference("Omar2023", "M. H. Omar, M. A. Rahim, M. N. A. M. Rejab",
              "Numerical Study on the Torsional and Lateral Vibrations of Double Universal Joint Driveline System",
              "International Journal of Automotive and Mechanical Engineering (IJAME)", 2023,
              used_for="DoubleCardanDriveline, torsionally elastic shaft (Eqs. 1-19, Table 1, Figs. 4-12)"),
)

BY_KEY = {r.key: r for r in REFERENCES}

#: the sources of each FMU (its documentation lists them first)
FMU_SOURCES = {
    "CardanJoint": ("Feng2012",),
    "DoubleCardanDriveline": ("Brutti1999", "Omar2023"),
    "TwinJeffcottRotor": ("Tchomeni2019",),
    "RingCoupling": ("Turla2002",),
    "Motor": (),
    "Load": ("Brutti1999",),
    "CardanJointTorqueDriven": ("Feng2012",),
    "DoubleCardanDrivelineTorqueDriven": ("Brutti1999", "Omar2023"),
    "MotorController": (),
    "TwinJeffcottRotorTorqueDriven": ("Tchomeni2019",),
    "RingCouplingTorqueDriven": ("Turla2002",),
}


def markdown() -> str:
    """docs/references.md."""
    lines = ["# References", "",
             "The papers the models come from, cited by key (e.g. [Feng2012]) in the code, the docs and every FMU's "
             "`documentation/index.html`, which carries this list too. Generated from `ujfmu/bibliography.py`; "
             "tests/test_docs.py checks that this file matches it. The papers contain typos; how each was read is "
             "in the model's document (ujfmu/models/cardan_joint/README.md, ujfmu/models/double_cardan_driveline/README.md, ujfmu/models/twin_jeffcott_rotor/README.md, "
             "ujfmu/models/ring_coupling/README.md). A DOI is given only where verified; otherwise the publisher's page, if "
             "known.", "",
             "| key | reference | used for |", "| --- | --- | --- |"]
    lines += [f"| [{r.key}] | {r.text()} | {r.used_for} |" for r in REFERENCES]
    return "\n".join(lines) + "\n"
