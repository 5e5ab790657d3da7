"""Graphics: the moderngl renderer, the pyglet window (`twig play`) and offscreen output."""
