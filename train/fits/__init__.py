"""Parts fit onto a trained model after training: the joint reading head, the albedo correction."""
