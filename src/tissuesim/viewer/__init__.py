"""The interactive simulator of §8.2 / §8.4 and the paper's figures, drawn with polyscope.

* :mod:`.controller` — the interaction logic (pointer and key events → PinHead / Scalpel; fixed-dt stepping);
  plain Python, no OpenGL;
* :mod:`.app` — the window: a thin polyscope layer over the controller, with the ImGui panel;
* :mod:`.figures` — Fig 11 (deformation) and Fig 16 (incision) rendered offscreen (EGL);
* :mod:`.gl` — the only place polyscope is imported and initialised.
"""
