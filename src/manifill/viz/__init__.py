"""Pictures: off-screen renders (:mod:`manifill.viz.render`), the interactive page (:mod:`manifill.viz.viewer`,
``viewer.html``) and the paper's figures redrawn by the demo (:mod:`manifill.viz.figures`)."""
